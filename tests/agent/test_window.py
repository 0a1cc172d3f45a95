"""The rolling window against a batch computation of the same tail, without broker or sleeps."""

import numpy as np

from stiction.agent.coded_ring import fitted_step
from stiction.agent.window import RollingWindow


def test_window_is_always_the_tail_of_the_stream():
    rng = np.random.default_rng(0)
    stream = rng.normal(size=5000)
    w = RollingWindow(300, 1.0)
    seq = 0
    while seq < stream.size:
        n = int(rng.integers(1, 700)) if rng.random() < 0.5 else int(rng.integers(1, 12))  # a message of a few seconds
        part = stream[seq : seq + n]
        if rng.random() < 0.5:  # as numpy arrays, or as the lists a decoded message carries
            w.update(seq, float(seq), part, -part)
        else:
            w.update(seq, float(seq), part.tolist(), (-part).tolist())
        seq += part.size
        op, pv = w.get()
        expected = stream[max(0, seq - 300) : seq]
        around = stream[max(0, seq - 900) : seq]  # the grids' samples: this window, the one before, the overwritten
        err = fitted_step(around.min(), around.max())  # the codes' step
        assert np.all(np.abs(op - expected) <= err) and np.all(np.abs(pv + expected) <= err)
        assert w.t_end_s == seq - 1 and w.next_seq == seq
    assert w.snapshot()["count"] == 300
    assert w.holds(seq - 10, stream[seq - 10 : seq], -stream[seq - 10 : seq])  # a repeat of float64 samples is seen


def test_the_setpoint_is_kept_beside_the_window_and_costs_nothing_while_it_stands_still():
    w = RollingWindow(100, 1.0)
    w.update(0, 0.0, np.zeros(60), np.zeros(60), np.full(60, 50.0))
    assert w._sp is None and np.array_equal(w.get_sp(), np.full(60, 50.0))  # one number, no ring
    w.update(60, 60.0, np.zeros(3), np.zeros(3), [50.0, 52.0, 52.0])  # the operator moves it
    w.update(63, 63.0, np.zeros(57), np.zeros(57), np.full(57, 52.0))
    sp = w.get_sp()
    assert sp.size == 100 and np.all(sp[:41] == 50.0) and np.all(sp[41:] == 52.0)  # seq 20..60 at 50, then 52
    w.update(120, 120.0, np.zeros(10), np.zeros(10))  # a batch without a setpoint
    assert w.get_sp() is None
    w.update(130, 130.0, np.zeros(100), np.zeros(100), np.full(100, 52.0))  # slid out of the window
    assert np.array_equal(w.get_sp(), np.full(100, 52.0))


def test_the_valve_position_is_kept_beside_the_window_only_where_the_stream_has_it():
    w = RollingWindow(100, 1.0)
    w.update(0, 0.0, np.zeros(60), np.zeros(60))
    assert w._mv is None and w.get_mv() is None  # a stream without it costs no ring
    w.update(60, 60.0, np.zeros(50), np.zeros(50), mv=np.arange(60.0, 110.0))
    assert w.get_mv() is None  # the window still holds samples that had none
    w.update(110, 110.0, np.zeros(60), np.zeros(60), mv=np.arange(110.0, 170.0))
    assert np.array_equal(w.get_mv(), np.arange(70.0, 170.0))  # the last 100, oldest first
    w.update(170, 170.0, np.zeros(5), np.zeros(5))  # a batch without it
    assert w.get_mv() is None
    w.update(175, 175.0, np.zeros(100), np.zeros(100), mv=np.full(100, 3.0))
    assert np.array_equal(w.get_mv(), np.full(100, 3.0))


def test_the_setpoint_is_the_tail_of_the_stream_whether_kept_as_steps_or_as_a_ring():
    """Setpoints that step now and then, that move every sample (a cascade's inner loop), and batches that carry
    none; the reference is the stream's tail, None while the window holds a sample that had no setpoint."""
    from stiction.agent.window import SP_STEPS_KEPT

    rng = np.random.default_rng(3)
    for kind in ("steps", "moving", "steps then moving"):
        size, total = 200, 3000
        sp = np.repeat(rng.uniform(20, 80, 12), total // 12)  # a dozen steps
        if kind != "steps":
            moving = np.cumsum(rng.normal(0, 0.1, total)) + 50.0
            sp = moving if kind == "moving" else np.r_[sp[: total // 2], moving[total // 2 :]]
        has = np.ones(total, bool)
        w = RollingWindow(size, 1.0)
        seq = 0
        while seq < total:
            n = min(int(rng.integers(1, 300)) if rng.random() < 0.3 else int(rng.integers(1, 6)), total - seq)
            part = sp[seq : seq + n]
            given = rng.random() > 0.03
            has[seq : seq + n] = given
            w.update(seq, float(seq), np.zeros(n), np.zeros(n), (part.tolist() if rng.random() < 0.5 else part)
                     if given else None)  # fmt: skip
            seq += n
            lo = max(0, seq - size)
            got = w.get_sp()
            if not has[lo:seq].all():
                assert got is None
            else:
                np.testing.assert_array_equal(got, sp[lo:seq].astype(np.float32))
            if kind == "steps":
                assert w._sp is None and len(w._sp_steps or ()) <= SP_STEPS_KEPT  # a few numbers, never a ring
        if kind != "steps":
            assert w._sp is not None and w._sp_steps is None  # moving every sample: kept as a ring


def test_a_ring_shorter_than_a_message_keeps_the_messages_tail():
    """Hidden effect: a batch of a few samples longer than the whole window (a window of 5, messages of 8)."""
    w = RollingWindow(5, 1.0)
    stream = np.arange(40.0) * 1.5
    for seq in range(0, 40, 8):
        w.update(seq, float(seq), stream[seq : seq + 8].tolist(), (-stream[seq : seq + 8]).tolist())
        op, pv = w.get()
        np.testing.assert_allclose(op, stream[seq + 3 : seq + 8], atol=1e-9)
        np.testing.assert_allclose(pv, -stream[seq + 3 : seq + 8], atol=1e-9)
    assert len(w._op.buf) == 3 * 5  # the ring never grows
