"""The agent's pure core: ownership, due windows and every rejection reason, without a network."""

import json

import numpy as np
import pytest

from stiction.agent.coded_ring import CODES_FITTED
from stiction.agent.core import AgentCore, CoreSettings

KEY = "stiction/demo/loop/L1/samples"
JSON = "application/json"


def _payload(seq, n=10, loop_id="L1", **kw):
    body = {
        "schema_version": 1,
        "loop_id": loop_id,
        "seq": seq,
        "t0_s": float(seq),
        "ts_s": 1.0,
        "op": list(np.arange(seq, seq + n, dtype=float)),
        "pv": [0.0] * n,
    } | kw
    return json.dumps(body).encode()


def _due(core, now_s=None):
    """The windows due, each built as the agent builds a batch's: (window, arrival of its last sample)."""
    return [(core.window(d), d.arrived_s) for d in core.due_loops(now_s)]


def _core(**kw):
    return AgentCore("a1", CoreSettings(window_samples=100, report_every_samples=20, **kw))


def test_loops_are_shared_between_agents_exactly_once_and_taken_over():
    a, b = AgentCore("a"), AgentCore("b")
    for core in (a, b):
        core.set_agents({"a", "b"})
    loops = [f"L{i}" for i in range(400)]
    owners = [(a.owns(x), b.owns(x)) for x in loops]
    assert all(oa != ob for oa, ob in owners)
    assert 150 < sum(oa for oa, _ in owners) < 250
    a.set_agents({"a"})  # b's token disappeared
    assert all(a.owns(x) for x in loops)


def test_window_due_once_full_and_then_every_report_interval():
    core = _core()
    for seq in range(0, 90, 10):
        core.ingest(KEY, _payload(seq), JSON, float(seq))
    assert _due(core) == []
    core.ingest(KEY, _payload(90), JSON, 90.0)
    due = _due(core)
    assert len(due) == 1 and due[0][0].op[-1] == 99 and due[0][1] == 90.0
    core.ingest(KEY, _payload(100), JSON, 100.0)
    assert _due(core) == []
    core.ingest(KEY, _payload(110), JSON, 110.0)
    assert len(_due(core)) == 1


@pytest.mark.parametrize(
    ("payload", "encoding", "reason"),
    [
        (b'{"schema_version": 1, "loop_id": ', JSON, "malformed_json"),
        (_payload(0, schema_version=2), JSON, "wrong_schema_version"),
        (json.dumps({"schema_version": 1, "loop_id": "L1", "seq": 0}).encode(), JSON, "missing_field"),
        (_payload(0).replace(b"0.0]", b"NaN]"), JSON, "not_finite"),
        (_payload(0).replace(b"0.0]", b"Infinity]"), JSON, "not_finite"),
        (_payload(0, n=4000), JSON, "oversized_batch"),
        (_payload(0), "text/plain", "wrong_encoding"),
        (_payload(0, loop_id="L2"), JSON, "loop_id_mismatch"),
        (b"x" * 600_000, JSON, "oversized_payload"),
    ],
)
def test_bad_messages_are_counted_by_reason(payload, encoding, reason):
    core = _core()
    core.ingest(KEY, payload, encoding, 0.0)
    assert dict(core.rejected) == {reason: 1}
    assert core.samples == 0


def test_duplicate_out_of_order_and_gap():
    core = _core()
    core.ingest(KEY, _payload(0), JSON, 0.0)
    core.ingest(KEY, _payload(10), JSON, 0.0)
    core.ingest(KEY, _payload(10), JSON, 0.0)  # the same samples again: duplicate
    core.ingest(KEY, _payload(5, op=[7.0] * 10), JSON, 0.0)  # other samples for seq 5..14: out of order
    core.ingest(KEY, _payload(40), JSON, 0.0)  # 20 samples missing: the window restarts there
    assert dict(core.rejected) == {"duplicate": 1, "out_of_order": 1, "gap": 1}
    assert core.loops["L1"].window.count == 10 and core.samples == 30


def test_burst_of_unknown_loops_is_capped():
    core = _core(max_loops=5)
    for i in range(8):
        core.ingest(f"stiction/demo/loop/X{i}/samples", _payload(0, loop_id=f"X{i}"), JSON, 0.0)
    assert len(core.loops) == 5 and core.rejected["too_many_loops"] == 3


def test_other_agents_loops_are_not_even_parsed():
    core = _core(replicas=1)
    core.set_agents({"a1", "zz"})
    mine = [f"L{i}" for i in range(50) if core.owns(f"L{i}")]
    theirs = [f"L{i}" for i in range(50) if not core.owns(f"L{i}")]
    for lid in theirs[:3]:
        core.ingest(f"stiction/demo/loop/{lid}/samples", b"not json at all", JSON, 0.0)
    assert not core.rejected and mine


def test_a_new_loop_reports_a_partial_window_first_then_grows_to_the_full_one():
    settings = CoreSettings(window_samples=300, report_every_samples=50, first_report_samples=120, stagger=False)
    core = AgentCore("a1", settings)
    for seq in range(0, 110, 10):
        core.ingest(KEY, _payload(seq), JSON, float(seq))
    assert _due(core) == []  # 110 samples: not yet
    core.ingest(KEY, _payload(110), JSON, 110.0)
    (first, _), *rest = _due(core)
    assert not rest and len(first.op) == 120 and first.full_samples == 300
    sizes = []
    for seq in range(120, 400, 10):
        core.ingest(KEY, _payload(seq), JSON, float(seq))
        sizes += [len(w.op) for w, _ in _due(core)]
    assert sizes == [170, 220, 270, 300, 300]  # every 50 new samples, the window never beyond 300


def test_the_due_window_carries_the_streamed_valve_position_through_a_short_gap_and_an_inherited_history():
    core = _core(max_fill_samples=5)
    for seq in range(0, 60, 10):
        core.ingest(KEY, _payload(seq, mv=list(np.arange(seq, seq + 10) + 0.5)), JSON, 0.0)
    core.ingest(KEY, _payload(63, n=37, mv=list(np.arange(63, 100) + 0.5)), JSON, 0.0)  # seq 60..62 missing
    (w, _), *_ = _due(core)
    np.testing.assert_allclose(w.mv, np.arange(0, 100) + 0.5)  # the gap's stem drawn straight across it
    key = _sharded_key("L1")
    heir = _core()
    heir.ingest(key, _payload(90, n=10, mv=[1.0] * 10), JSON, 1.0)
    heir.ingest(key, _payload(0, n=92, mv=[2.0] * 92), JSON, 2.0, history=True)  # the publisher's, with its stem
    np.testing.assert_array_equal(heir.loops["L1"].window.get_mv(), [2.0] * 90 + [1.0] * 10)


def test_a_short_gap_is_interpolated_and_counted_a_long_one_restarts_the_window():
    core = AgentCore("a1", CoreSettings(window_samples=100, report_every_samples=200, max_fill_samples=5))
    core.ingest(KEY, _payload(0, n=50), JSON, 0.0)  # op = seq
    core.ingest(KEY, _payload(54, n=10, op=[100.0] * 10), JSON, 0.0)  # seq 50..53 missing
    op, _ = core.loops["L1"].window.get()
    assert core.loops["L1"].window.count == 64 and not core.rejected
    np.testing.assert_allclose(op[49:55], [49.0, 59.2, 69.4, 79.6, 89.8, 100.0], atol=100 / CODES_FITTED)
    assert (core.gaps_filled, core.samples_filled) == (1, 4)
    assert core.loops["L1"].interpolated() == 4
    core.ingest(KEY, _payload(64, n=40), JSON, 0.0)  # the gap stays inside the 100-sample window
    assert core.loops["L1"].interpolated() == 4
    core.ingest(KEY, _payload(104, n=60), JSON, 0.0)  # and then slides out of it
    assert core.loops["L1"].interpolated() == 0
    core.ingest(KEY, _payload(170), JSON, 0.0)  # 6 missing > 5: the window restarts
    assert core.rejected["gap"] == 1 and core.loops["L1"].window.count == 10


def test_first_reports_of_loops_started_together_are_spread_over_the_report_interval():
    core = AgentCore("a1", CoreSettings(window_samples=1000, report_every_samples=60, first_report_samples=100))
    first_at = {}
    for seq in range(0, 200, 10):
        for i in range(300):
            lid = f"L{i}"
            core.ingest(f"stiction/demo/loop/{lid}/samples", _payload(seq, loop_id=lid), JSON, 0.0)
        for w, _ in _due(core):
            first_at.setdefault(w.loop_id, len(w.op))
    assert len(first_at) == 300
    sizes = np.array(list(first_at.values()))
    assert sizes.min() >= 100 and sizes.max() < 170  # within one report interval (and one batch) of 100
    assert np.bincount((sizes - 100) // 10).max() < 300 / 6 * 1.5  # about evenly spread, not all at once


def test_after_the_owner_dies_the_replica_reports_every_interval_exactly_once():
    a, b = AgentCore("a", CoreSettings(window_samples=200, report_every_samples=50)), None
    b = AgentCore("b", CoreSettings(window_samples=200, report_every_samples=50))
    for core in (a, b):
        core.set_agents({"a", "b"})
    loops = [f"L{i}" for i in range(40)]
    reported: dict[str, list[float]] = {lid: [] for lid in loops}
    for seq in range(0, 1000, 10):
        if seq == 500:
            b.set_agents({"b"})  # a is killed: its token vanishes, b takes over
        for lid in loops:
            payload = _payload(seq, loop_id=lid)
            for core in (a, b) if seq < 500 else (b,):
                core.ingest(f"stiction/demo/loop/{lid}/samples", payload, JSON, 0.0)
        for core in (a, b) if seq < 500 else (b,):
            for w, _ in _due(core):
                reported[w.loop_id].append(w.op[-1])  # the window's last sample names the interval
    for lid, ends in reported.items():
        steps = np.diff(ends)
        assert len(ends) >= 15 and np.all(steps == 50), (lid, ends)  # one report each 50 samples, none twice


def test_the_due_window_carries_the_streamed_setpoint():
    core = _core()
    for seq in range(0, 100, 10):
        core.ingest(KEY, _payload(seq, sp=[float(seq)] * 10), JSON, 0.0)
    (w, _), *_ = _due(core)
    np.testing.assert_array_equal(w.sp, np.repeat(np.arange(0, 100, 10), 10).astype(np.float32))
    plain = _core()
    for seq in range(0, 100, 10):
        plain.ingest(KEY, _payload(seq), JSON, 0.0)
    assert _due(plain)[0][0].sp is None


def test_a_sticky_loop_carries_its_friction_reading_for_estimate_every_reports():
    from stiction.quantify.window import Reading

    core = _core(estimate_every=3)
    seq = 0

    def next_due():
        nonlocal seq
        while True:
            core.ingest(KEY, _payload(seq), JSON, float(seq))
            seq += 10
            due = _due(core)
            if due:
                return due[0][0]

    first = next_due()
    assert first.carry is None
    reading = Reading({"fs_pct": 12.0}, (), first.t_end_s)
    core.reported("L1", "stiction", reading)
    carries = []
    for _ in range(4):
        w = next_due()
        carries.append(w.carry)
        core.reported("L1", "stiction", None if w.carry is not None else Reading({"fs_pct": 13.0}, (), w.t_end_s))
    # read at the first report, carried by the next two (three reports in all), read afresh at the fourth
    assert carries[0] is reading and carries[1] is reading and carries[2] is None
    assert carries[3].fields == {"fs_pct": 13.0}
    core.reported("L1", "other_cause", None)  # no longer sticky: the reading is dropped
    assert next_due().carry is None
    core.reported("L1", "stiction", reading)
    core.ingest(KEY, _payload(seq + 50), JSON, float(seq + 50))  # a gap too long to fill: the window restarts
    seq += 60
    assert next_due().carry is None


def test_a_fitted_reading_adopted_from_the_background_is_carried_until_it_expires():
    from stiction.quantify.window import Reading

    core = _core(estimate_every=2)
    seq = 0

    def next_due(now_s):
        nonlocal seq
        while True:
            core.ingest(KEY, _payload(seq), JSON, float(seq))
            seq += 10
            due = [core.window(d) for d in core.due_loops(now_s)]
            if due:
                return due[0]

    w = next_due(0.0)
    assert not core.adopt("L1", Reading({"fs_pct": 1.0}), 99.0)  # not called sticky yet: nothing to carry
    core.reported("L1", "stiction", Reading({"fs_pct": 12.0}, (), w.t_end_s), w.t_end_s)
    fitted = Reading({"fs_pct": 12.5}, ("fitted",), w.t_end_s)
    assert core.adopt("L1", fitted, keep_until_s=100.0)
    carried = []
    for now_s in (10.0, 20.0, 30.0, 100.0):
        w = next_due(now_s)
        carried.append(w.carry)
        core.reported("L1", "stiction", None if w.carry is not None else Reading({"fs_pct": 13.0}), w.t_end_s)
    # estimate_every (2) would read afresh at the second report; the fit is carried until 100 s, then read afresh
    assert carried[:3] == [fitted] * 3 and carried[3] is None
    core.reported("L1", "other_cause", None)  # no longer sticky: a fit coming back late is not taken
    assert not core.adopt("L1", fitted, 1e9)
    assert next_due(200.0).carry is None


def test_fresh_readings_are_rationed_while_the_agent_is_behind_never_read_ones_first():
    from stiction.quantify.window import Reading

    core = AgentCore("a1", CoreSettings(window_samples=100, report_every_samples=100, stagger=False,
                                        estimate_every=4, reading_lag_s=0.5))  # fmt: skip
    loops = [f"L{i:03d}" for i in range(100)]

    def pass_(start, now_s):
        for lid in loops:
            core.ingest(f"stiction/demo/loop/{lid}/samples", _payload(start, n=100, loop_id=lid), JSON, 10.0 * start)
        return {w.loop_id: w for w, _ in _due(core, now_s)}

    due = pass_(0, now_s=0.2)  # every loop due at once, but the agent keeps up: every reading made
    assert len(due) == 100 and not any(w.defer_reading or w.carry for w in due.values())
    for lid in due:
        core.reported(lid, "stiction" if lid != "L000" else "other_cause", None)  # as if their readings failed
    due = pass_(100, now_s=1000.0 + 2.0)  # 2 s behind: a quarter of the due loops are read
    granted = {lid for lid, w in due.items() if not w.defer_reading}
    # L000 was last called not sticky: read at once should it turn sticky, outside the ration of 25
    assert "L000" in granted and len(granted) == 26 and core.readings_deferred == 74
    granted.discard("L000")
    for lid, w in due.items():
        core.reported(lid, "stiction", Reading({}, (), w.t_end_s) if lid in granted else None)
    due = pass_(200, now_s=2000.0 + 2.0)
    now = {lid for lid, w in due.items() if not w.defer_reading and w.carry is None}
    assert len(now) == 25 and not now & granted  # the loops never read go first
    assert all(due[lid].carry is not None and not due[lid].defer_reading for lid in granted)


def test_due_from_the_queue_equals_a_scan_of_every_loop():
    """``due`` looks only at loops queued as they were ingested; a brute-force scan of every loop
    held (the rule itself) must name the same loops, through gaps, restarts and partial first windows."""
    rng = np.random.default_rng(11)
    core = AgentCore("a1", CoreSettings(window_samples=100, report_every_samples=20, first_report_samples=100))
    next_seq = dict.fromkeys(range(30), 0)
    reported = 0
    for _ in range(1500):
        i = int(rng.integers(30))
        seq = next_seq[i] + (int(rng.integers(1, 40)) if rng.random() < 0.05 else 0)  # now and then a gap
        n = int(rng.integers(1, 15))
        core.ingest(f"stiction/demo/loop/L{i}/samples", _payload(seq, n=n, loop_id=f"L{i}"), JSON, 0.0)
        next_seq[i] = seq + n
        if rng.random() < 0.2:
            scan = {
                lid
                for lid, st in core.loops.items()
                if st.window.count >= st.first_at and st.new_since_report >= core.settings.report_every_samples
            }
            assert {w.loop_id for w, _ in _due(core)} == scan
            reported += len(scan)
    assert reported > 50


def test_a_replica_taking_over_late_does_not_report_a_window_the_dead_owner_had_reported():
    a, b = (AgentCore(x, CoreSettings(window_samples=100, report_every_samples=20, stagger=False)) for x in "ab")
    for core in (a, b):
        core.set_agents({"a", "b"})
    loop = next(f"L{i}" for i in range(100) if a.owns(f"L{i}"))
    key = f"stiction/demo/loop/{loop}/samples"
    for seq in range(0, 100, 10):
        for core in (a, b):
            core.ingest(key, _payload(seq, loop_id=loop), JSON, float(seq))
    ((window, _),) = _due(a)  # the owner reports the window ending at 99 ...
    report = json.dumps({"loop_id": loop, "t_end_s": window.t_end_s}).encode()
    b.seen_report(f"stiction/demo/loop/{loop}/report", report)
    b.set_agents({"b"})  # ... and dies before the replica, behind, has looked at that window
    assert _due(b) == []
    for seq in range(100, 120, 10):
        b.ingest(key, _payload(seq, loop_id=loop), JSON, float(seq))
    ((later, _),) = _due(b)  # the next window is the replica's
    assert later.t_end_s == window.t_end_s + 20
    b.seen_report(f"stiction/demo/loop/{loop}/report", b"not json")  # ignored, never raised


def test_an_agent_that_gets_a_loop_back_does_not_report_again_what_it_had_reported_itself():
    """The service does not hear its own reports back from the key space: ``reported`` keeps their ends, so a
    loop that leaves for a joining agent and comes back, its history merged again, resumes after the last report
    this agent made (not from the start of the history)."""
    a = AgentCore("a", CoreSettings(window_samples=100, report_every_samples=20, stagger=False))
    loop = next(f"L{i}" for i in range(100) if AgentCore("a").owns(f"L{i}"))
    key = _sharded_key(loop)
    for seq in range(0, 100, 10):
        a.ingest(key, _payload(seq, loop_id=loop), JSON, float(seq))
    ((window, _),) = _due(a)
    a.reported(loop, "stiction", None, window.t_end_s)
    b_owns = next(agent for agent in (f"b{i}" for i in range(100)) if not _with(agent).owns(loop))
    a.set_agents({"a", b_owns})
    a.set_agents({"a"})  # the shard went to the other agent, which died before reporting it
    assert loop not in a.loops
    a.ingest(key, _payload(0, n=110, loop_id=loop), JSON, 200.0, history=True)  # the publisher's last 110 samples
    assert a.reported_to_s[loop] == window.t_end_s
    assert _due(a) == []  # 10 samples after its own last report: not due (every 20)
    a.ingest(key, _payload(110, loop_id=loop), JSON, 210.0)
    ((later, _),) = _due(a)
    assert later.t_end_s == window.t_end_s + 20  # the next interval, on the schedule


def _with(other):
    """A core of agent ``a`` beside ``other``: who owns what once both are alive."""
    core = AgentCore("a")
    core.set_agents({"a", other})
    return core


def _reference_owner(agents, shard):
    """Plain rendezvous hashing, no cap: the agent ranking first for the shard."""
    from stiction.agent.ownership import rank

    return max(agents, key=lambda a: rank(a, f"shard/{shard}"))


@pytest.mark.parametrize("n", [1, 2, 3, 5, 32])
def test_shards_are_given_out_evenly_and_every_agent_computes_the_same(n):
    from stiction.agent.ownership import assign
    from stiction.schemas import keys

    agents = tuple(f"agent-{i}" for i in range(n))
    owners = assign(agents)
    assert len(owners) == keys.SHARDS and set(owners) <= set(agents)
    counts = [owners.count(a) for a in agents]
    assert max(counts) - min(counts) <= 1, counts  # even shares, as near as the number allows
    assert assign(tuple(reversed(agents))) == owners
    cores = [AgentCore(a) for a in agents]
    for core in cores:
        core.set_agents(set(agents))
    for k in range(keys.SHARDS):  # each shard owned by exactly one agent, and it is assign's
        assert [c.agent_id for c in cores if c.shard_role(k) == 0] == [owners[k]]
    # rendezvous still decides: most shards go to the agent that ranks first for them
    agree = sum(owners[k] == _reference_owner(agents, k) for k in range(keys.SHARDS))
    assert agree >= keys.SHARDS // 2


def test_the_heir_of_a_shard_owns_it_once_its_owner_is_gone():
    from stiction.agent.ownership import assign
    from stiction.schemas import keys

    agents = ("a", "b", "c")
    cores = {x: AgentCore(x) for x in agents}
    for core in cores.values():
        core.set_agents(set(agents))
    owners = assign(agents)
    for k in range(keys.SHARDS):
        heirs = [x for x, c in cores.items() if c.shard_role(k) == 1]
        assert len(heirs) == 1 and heirs[0] != owners[k]
        survivors = tuple(x for x in agents if x != owners[k])
        assert assign(survivors)[k] == heirs[0]


def _sharded_key(loop_id):
    from stiction.schemas import keys

    return keys.sharded_samples("stiction/demo", loop_id)


def test_an_inherited_loops_window_is_its_history_then_what_came_live_and_keeps_the_schedule():
    core = _core()
    key = _sharded_key("L1")
    # the dead owner reported the window ending at t=79; live samples 90.. came before the history
    core.seen_report("stiction/demo/loop/L1/report", json.dumps({"t_end_s": 79.0}).encode())
    core.ingest(key, _payload(90, n=5), JSON, 1.0)
    core.ingest(key, _payload(0, n=92), JSON, 2.0, history=True)  # the publisher's last 92 samples
    op, _ = core.loops["L1"].window.get()
    np.testing.assert_array_equal(op, np.arange(0, 95))  # history in front, the live samples behind
    assert core.history_merged == 1
    assert _due(core) == []  # 15 samples since the last report: not due yet (every 20)
    core.ingest(key, _payload(95, n=4), JSON, 3.0)
    assert _due(core) == []
    core.ingest(key, _payload(99, n=1), JSON, 4.0)  # the 20th sample after t=79
    ((window, _),) = _due(core)
    assert window.t_end_s == 99.0 and len(window.op) == 100


def test_live_samples_a_publishers_history_brought_first_are_repeats_and_a_batch_past_it_keeps_its_new_tail():
    """Hidden effect: a history reply (values rounded to six decimals, ``bridge.history``) lands before the live
    batches it holds, as when an agent starts while a publisher fills the windows.  The live repeat is a duplicate,
    not other samples; a live batch reaching past the history keeps its new samples; every sample counts once."""
    core = _core()
    key = _sharded_key("L1")
    exact = 50.0 + np.arange(100) / 3.0  # values whose six-decimal rounding moves their float32
    core.ingest(key, _payload(0, n=92, op=list(np.round(exact[:92], 6))), JSON, 1.0, history=True)
    core.ingest(key, _payload(0, n=92, op=list(exact[:92])), JSON, 1.1)  # the same samples, live
    assert dict(core.rejected) == {"duplicate": 1} and core.samples == 92
    core.ingest(key, _payload(88, n=7, op=list(exact[88:95])), JSON, 1.2)  # 88..91 held, 92..94 new
    core.ingest(key, _payload(95, n=5, op=list(exact[95:100])), JSON, 1.3)
    op, _ = core.loops["L1"].window.get()
    np.testing.assert_allclose(op, exact, atol=(exact.max() - exact.min()) / CODES_FITTED)  # the codes' step
    assert dict(core.rejected) == {"duplicate": 1} and core.samples == 100
    core.ingest(key, _payload(97, n=5, op=[0.0] * 5), JSON, 1.4)  # other values for held samples: refused
    assert core.rejected["out_of_order"] == 1 and core.samples == 100


def test_a_repeat_is_told_within_the_rounding_a_publishers_history_applies():
    from stiction.agent.window import REPEAT_ATOL
    from stiction.bridge.history import DECIMALS

    assert 0.5 * 10.0**-DECIMALS <= REPEAT_ATOL < 1e-4  # the history's rounding, and far below any transmitter's step


def test_a_history_that_does_not_reach_the_live_window_is_refused_and_the_window_goes_on():
    core = _core()
    key = _sharded_key("L1")
    core.ingest(key, _payload(50, n=10), JSON, 1.0)
    core.ingest(key, _payload(0, n=30), JSON, 2.0, history=True)
    assert core.rejected["history_gap"] == 1
    op, _ = core.loops["L1"].window.get()
    np.testing.assert_array_equal(op, np.arange(50, 60))


def test_a_sharded_loop_is_held_by_its_owner_only_and_dropped_when_its_shard_moves():
    from stiction.schemas import keys

    loops = [f"L{i}" for i in range(60)]
    a = AgentCore("a", CoreSettings(window_samples=100, report_every_samples=20))
    a.set_agents({"a"})
    for lid in loops:
        a.ingest(_sharded_key(lid), _payload(0, loop_id=lid), JSON, 0.0)
    assert len(a.loops) == len(loops)
    a.set_agents({"a", "b"})  # b joins: a keeps only the loops of its own shards
    assert set(a.loops) == {lid for lid in loops if a.owns(lid)}
    assert 0 < len(a.loops) < len(loops)
    wrong = keys.samples("stiction/demo", "L1") + f"/{(keys.shard_of('L1') + 1) % keys.SHARDS}"
    a.ingest(wrong, _payload(10), JSON, 1.0)
    assert a.rejected["wrong_shard"] == 1
    a.ingest(wrong, _payload(10), JSON, 1.5)
    assert a.rejected["wrong_shard"] == 2  # a wrong key is refused every time, never remembered
    for lid in loops:  # keys seen before the membership changed: whose loop it is is asked afresh
        a.ingest(_sharded_key(lid), _payload(10, loop_id=lid), JSON, 2.0)
    assert set(a.loops) == {lid for lid in loops if a.owns(lid)}
    assert all(a.loops[lid].window.next_seq == 20 for lid in a.loops)


def test_the_window_for_a_background_sizing_is_the_loops_newest_and_only_an_owned_ones():
    """The sizing queue keeps loop ids; the window it sizes is taken when the worker is free: the newest."""
    core = _core()
    core.set_agents({"a1"})
    assert core.window_of("L1") is None  # never seen
    core.ingest(KEY, _payload(0, n=60), JSON, 0.0)
    core.ingest(KEY, _payload(60, n=60), JSON, 1.0)
    w = core.window_of("L1")
    assert w.loop_id == "L1" and len(w.op) == 100 and w.t_end_s == 119.0 and w.full_samples == 100
    np.testing.assert_array_equal(w.op, np.arange(20, 120, dtype=np.float32))
    for other in (f"b{i}" for i in range(50)):  # an agent that takes L1's shard over
        core.set_agents({"a1", other})
        if not core.owns("L1"):
            break
    assert not core.owns("L1") and core.window_of("L1") is None  # handed over: its new owner sizes it
