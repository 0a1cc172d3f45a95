"""A publisher's memory of each loop's recent samples, as an agent taking a shard over asks for it."""

import json

import numpy as np

from stiction.bridge.history import SampleHistory
from stiction.schemas import keys
from stiction.schemas.messages import SampleBatch

P = "plant/a"


def _batch(loop_id, seq, n, sp=True):
    op = np.arange(seq, seq + n, dtype=float)
    return {"loop_id": loop_id, "seq": seq, "t0_s": 10.0 * seq, "ts_s": 10.0, "op": op, "pv": -op,
            "sp": np.full(n, 50.0) if sp else None, "process": None}  # fmt: skip


def _read(payload) -> SampleBatch:
    return SampleBatch.model_validate_json(payload)


def test_the_last_samples_of_each_loop_of_a_shard_come_back_as_one_valid_batch():
    h = SampleHistory(keep_samples=50)
    loops = [f"FIC{i}" for i in range(40)]
    for seq in range(0, 120, 7):  # batches of 7 wrap the ring several times
        for lid in loops:
            h.record(_batch(lid, seq, 7))
    shard = keys.shard_of(loops[0])
    answer = dict(h.answer(P, keys.shard_samples(P, shard), 30, sharded=True))
    expected = {keys.sharded_samples(P, lid) for lid in loops if keys.shard_of(lid) == shard}
    assert set(answer) == expected
    b = _read(answer[keys.sharded_samples(P, loops[0])])
    assert b.seq == 126 - 30 and b.op == list(np.arange(96, 126, dtype=float)) and b.pv == [-x for x in b.op]
    assert b.t0_s == 960.0 and b.sp == [50.0] * 30
    # more than it keeps: what it has
    key = keys.sharded_samples(P, loops[0])
    b = _read(dict(h.answer(P, key, 500, sharded=True))[key])
    assert len(b.op) == 50 and b.op[-1] == 125.0


def test_a_gap_or_a_column_that_comes_and_goes_restarts_the_history():
    h = SampleHistory(keep_samples=50)
    h.record(_batch("L", 0, 20))
    h.record(_batch("L", 25, 5))  # samples 20-24 never came
    b = _read(h.answer(P, "plant/a/loop/L/samples/**", 50, sharded=True)[0][1])
    assert b.seq == 25 and len(b.op) == 5
    h.record(_batch("L", 30, 5, sp=False))  # the setpoint stopped coming: only what every sample has
    body = json.loads(h.answer(P, "plant/a/loop/*/samples/*", 50, sharded=True)[0][1])
    assert body["seq"] == 30 and "sp" not in body


def test_queries_of_the_other_key_form_or_other_prefixes_are_not_answered():
    h = SampleHistory()
    h.record(_batch("L", 0, 5))
    assert h.answer(P, "plant/a/loop/L/samples", 5, sharded=True) == []  # published on its shard key
    assert h.answer(P, keys.sharded_samples(P, "L"), 5, sharded=False) == []
    assert len(h.answer(P, "plant/a/loop/L/samples", 5, sharded=False)) == 1
    assert h.answer(P, "plant/b/loop/*/samples/**", 5, sharded=True) == []
    assert h.answer(P, "plant/a/loop/M/samples/**", 5, sharded=True) == []
