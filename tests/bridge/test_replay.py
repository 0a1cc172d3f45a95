"""Replay: exports become streams that carry every sample once, in order, at the asked speed."""

import numpy as np

from stiction.bridge.replay import Schedule, Track, loop_ids
from stiction.schemas.messages import SampleBatch


def _track(loop_id, n, ts, t0=0.0):
    x = np.arange(n, dtype=float)
    return Track(loop_id, ts, t0, x, -x, sp=np.full(n, 3.0), mode=np.r_[np.ones(n - 1), np.nan])


def test_every_sample_goes_out_once_in_order_at_the_asked_speed():
    a, b = _track("a", 751, 10.0, t0=1.7e9), _track("b", 4000, 1.0)
    s = Schedule([a, b], speed=100.0)
    assert s.duration_s == 75.1
    got = {"a": [], "b": []}
    for elapsed in [0.0, 0.05, 1.0, 1.0, 2.55, 30.0, 74.9, 80.0]:
        for batch in s.due(elapsed):
            m = SampleBatch.model_validate(batch)
            assert m.seq == len(got[m.loop_id])  # no gap, no repeat
            assert m.t0_s == (1.7e9 if m.loop_id == "a" else 0.0) + m.seq * m.ts_s
            got[m.loop_id] += m.op
            if m.loop_id == "a":  # the time it went out: nothing before its time
                assert (m.seq + len(m.op) - 1) * 10.0 <= elapsed * 100.0
    assert s.done and got["a"] == a.op.tolist() and got["b"] == b.op.tolist()
    assert s.samples_published == 751 + 4000


def test_a_column_with_a_missing_value_is_left_out_of_that_batch_only():
    s = Schedule([_track("a", 10, 1.0)], speed=1.0)
    first, last = s.due(4.0), s.due(20.0)
    assert first[0]["mode"] == [1.0] * 5 and "mode" not in last[0] and last[0]["sp"] == [3.0] * 5


def test_loop_ids_are_key_safe_and_unique():
    ids = loop_ids(["x/stic_2#CDU.7040 FIC/1.csv", "y/stic_2#CDU.7040 FIC/1.csv", "z/#A*B?.csv", "w/a.b=1.csv"])
    assert ids == ["1", "1-2", "_A_B_", "a.b=1"]


def test_staggered_loops_each_send_once_an_interval_at_their_own_turn_and_lose_nothing():
    """At ``rate_hz`` with ``groups``, loop i sends at (m + (i mod groups) / groups) / rate_hz: what came
    due since its last turn, in one batch; over a run every sample goes out once, none before its time."""
    tracks = [_track(f"l{i}", 60, 1.0) for i in range(6)]
    s = Schedule(tracks, speed=1.0, rate_hz=0.2, groups=3)  # a batch every 5 s, turns 5/3 s apart
    assert s.step_s == 5.0 / 3
    sent_at: dict[str, list[float]] = {t.loop_id: [] for t in tracks}
    got: dict[str, list[float]] = {t.loop_id: [] for t in tracks}
    for k in range(0, 80):
        elapsed = k * s.step_s
        for batch in s.due(elapsed):
            m = SampleBatch.model_validate(batch)
            assert m.seq == len(got[m.loop_id]) and (m.seq + len(m.op) - 1) <= elapsed  # in order, none early
            got[m.loop_id] += m.op
            sent_at[m.loop_id].append(elapsed)
    assert s.done and all(got[t.loop_id] == t.op.tolist() for t in tracks)
    # each loop every 5 s, at its group's offset: l0 and l3 at 0, 5, 10 ...; l1 and l4 5/3 s later
    for i, t in enumerate(tracks):
        times = np.array(sent_at[t.loop_id])
        assert np.allclose(np.diff(times), 5.0)
        assert np.isclose(times[0] % 5.0, (i % 3) * 5.0 / 3)
    # in any one turn only one group of loops sends
    assert all(len({int(i[1:]) % 3 for i, at in sent_at.items() if np.isclose(at, x).any()}) == 1
               for x in {round(v, 6) for ts in sent_at.values() for v in ts})  # fmt: skip


def test_stagger_groups_cover_every_loop_once_and_step_the_interval():
    from stiction.bridge.publish import stagger_groups

    groups = stagger_groups(1000, 5.0)
    assert len(groups) == 100 and sorted(np.concatenate(groups).tolist()) == list(range(1000))
    assert len(stagger_groups(3, 5.0)) == 3 and len(stagger_groups(10, 0.01)) == 1


def test_the_exports_are_read_into_tracks_and_a_bad_or_short_one_is_named_with_its_error(tmp_path):
    from stiction.bridge.replay import read_tracks

    rows = [f"{k},{50 + k % 7},{40 + k % 5}\n" for k in range(300)]
    (tmp_path / "FIC101.csv").write_text("t,op,pv\n" + "".join(rows))
    (tmp_path / "bad.csv").write_text("t,op,pv\n0,1,2\n1,x,2\n")
    (tmp_path / "short.csv").write_text("t,op,pv\n" + "".join(rows[:200]))
    tracks, failed = read_tracks([tmp_path], None, "level", min_samples=250)
    assert [t.loop_id for t in tracks] == ["FIC101"] and tracks[0].op.size == 300 and tracks[0].process == "level"
    errors = {p.name: str(e) for p, e in failed}
    assert set(errors) == {"bad.csv", "short.csv"}
    assert "'x' is not a number" in errors["bad.csv"] and "need at least 250" in errors["short.csv"]
    # an export with a long gap in its time: the stretch after it is replayed, and the track says what was left out
    (tmp_path / "gap.csv").write_text("t,op,pv\n" + "".join(rows[:20] + rows[60:]))
    tracks, _ = read_tracks([tmp_path / "gap.csv"], None, None, min_samples=200)
    (gapped,) = tracks
    assert gapped.op.size == 240 and gapped.t0_s == 60 and len(gapped.notes) == 1 and "row 22" in gapped.notes[0]
    assert not read_tracks([tmp_path / "FIC101.csv"], None, None, min_samples=250)[0][0].notes
