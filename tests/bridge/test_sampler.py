"""The bridge's sampler: OPC UA value changes to SampleBatch, against a brute-force sample and hold."""

import math

import numpy as np
import pytest

from stiction.bridge.sampler import Reading, Sampler
from stiction.schemas.loop_file import LoopNodes
from stiction.schemas.messages import SampleBatch

NODES = LoopNodes(op="ns=2;s=A.OP", pv="ns=2;s=A.PV", sp="ns=2;s=A.SP")


def _r(role, value, t, good=True, loop="A"):
    return Reading(loop, role, value, good, t, t)


def _series(batches, role="op"):
    """seq -> value over every batch, each batch checked against the message schema."""
    out = {}
    for b in batches:
        SampleBatch.model_validate(b)
        out |= {b["seq"] + i: v for i, v in enumerate(b[role])}
    return out


def test_values_are_held_until_they_change_and_seq_counts_grid_points():
    s = Sampler({"A": NODES}, ts_s=1.0, settle_s=1.5)
    s.add(_r("pv", 5.0, 10.0))
    s.add(_r("op", 1.0, 10.2))
    assert s.due(12.0) == []  # grid point 10: OP not yet known
    s.add(_r("op", 2.0, 12.7))
    first = s.due(13.0)  # grid point 11
    assert [(b["seq"], b["t0_s"], b["op"], b["pv"]) for b in first] == [(0, 11.0, [1.0], [5.0])]
    assert "sp" not in first[0]  # SP never known: left out, not invented
    s.add(_r("sp", 50.0, 0.0))
    (b,) = s.due(16.0)  # grid points 12, 13, 14
    assert (b["seq"], b["op"], b["sp"]) == (1, [1.0, 2.0, 2.0], [50.0] * 3)
    assert s.samples_published == 4 and s.publishing == {"A"}


def test_a_bad_status_is_dropped_counted_and_leaves_a_gap_not_a_restart():
    s = Sampler({"A": NODES}, ts_s=1.0, settle_s=1.5)
    s.add(_r("pv", 5.0, 0.0))
    s.add(_r("op", 1.0, 0.0))
    s.due(11.5)  # starts at grid point 10
    s.add(_r("op", None, 10.5, good=False))
    s.add(_r("op", 3.0, 12.2))
    batches = s.due(15.5)  # 11, 12 unknown; 13, 14 known
    assert [(b["seq"], b["op"]) for b in batches] == [(3, [3.0, 3.0])]
    assert s.dropped == {"bad_status": 1}


def test_not_numbers_infinities_and_stale_changes_are_counted_by_reason():
    s = Sampler({"A": NODES}, ts_s=1.0)
    s.add(_r("op", "open", 1.0))
    s.add(_r("op", float("inf"), 2.0))
    s.add(_r("pv", 1.0, 5.0))
    s.add(_r("pv", 2.0, 4.0))  # older than the value already held
    assert s.dropped == {"not_a_number": 1, "not_finite": 1, "out_of_order": 1}


def test_after_a_lost_connection_the_first_value_counts_from_the_loss_not_from_its_old_timestamp():
    s = Sampler({"A": NODES}, ts_s=1.0, settle_s=0.5)
    s.add(_r("op", 1.0, 0.0))
    s.add(_r("pv", 1.0, 0.0))
    s.due(3.6)  # grid point 3 starts the loop
    s.disconnected(4.2)
    assert [(b["seq"], b["op"]) for b in s.due(8.6)] == [(1, [1.0])]  # grid point 4 was known; 5..8 are not
    s.add(_r("op", 1.0, 0.0))  # the server's current values after reconnecting: unchanged since t = 0
    s.add(_r("pv", 2.0, 7.0))
    (b,) = s.due(10.6)  # grid points 9, 10
    assert (b["seq"], b["op"], b["pv"]) == (6, [1.0, 1.0], [2.0, 2.0])


def test_a_missing_node_stops_its_loop_only_and_is_named():
    s = Sampler({"A": NODES, "B": NODES.model_copy(update={"pv": "ns=2;s=B.PV"})}, ts_s=1.0, settle_s=0.5)
    for loop in "AB":
        s.add(_r("op", 1.0, 0.0, loop=loop))
        s.add(_r("pv", 1.0, 0.0, loop=loop))
    s.node_missing("B", "pv", "BadNodeIdUnknown", 0.0)
    assert {b["loop_id"] for b in s.due(5.0)} == {"A"}
    assert s.missing == {"B": "pv node ns=2;s=B.PV: BadNodeIdUnknown"}
    s.add(_r("pv", 4.0, 5.2, loop="B"))  # the node is back
    assert {b["loop_id"] for b in s.due(7.0)} == {"A", "B"} and not s.missing


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_changes_match_a_brute_force_sample_and_hold(seed):
    rng = np.random.default_rng(seed)
    ts, settle = 0.5, 0.7
    readings = []
    for role in ("op", "pv"):
        times = np.sort(rng.uniform(0, 60, 80))
        for t in times:
            good = rng.uniform() > 0.1
            readings.append(_r(role, float(rng.normal()) if good else None, float(t), good))
    readings.sort(key=lambda r: r.source_t_s)
    s = Sampler({"A": NODES}, ts_s=ts, settle_s=settle)
    batches, now, i = [], 0.0, 0
    while now < 70:  # values arrive in time order; the sampler is asked at irregular moments
        now += rng.uniform(0.1, 3.0)
        while i < len(readings) and readings[i].source_t_s <= now - 0.2:
            s.add(readings[i])
            i += 1
        batches += s.due(now)

    def held(role, t):  # the last reading at or before t; unknown if that reading was bad
        last = [r for r in readings if r.role == role and r.source_t_s <= t]
        return last[-1].value if last and last[-1].good else math.nan

    got_op, got_pv = _series(batches, "op"), _series(batches, "pv")
    k0 = batches[0]["t0_s"] / ts
    expected = {}
    for k in range(int(k0), math.floor((now - settle) / ts) + 1):
        op, pv = held("op", k * ts), held("pv", k * ts)
        if math.isfinite(op) and math.isfinite(pv):
            expected[int(k - k0)] = (op, pv)
    assert {q: (got_op[q], got_pv[q]) for q in got_op} == expected
    assert s.dropped["bad_status"] == sum(not r.good for r in readings)
