"""The rolling window against a batch computation of the same tail, without broker or sleeps."""

import numpy as np

from agent.window import RollingWindow


def test_window_is_always_the_tail_of_the_stream():
    rng = np.random.default_rng(0)
    stream = rng.normal(size=5000)
    w = RollingWindow(300, 1.0)
    seq = 0
    while seq < stream.size:
        n = int(rng.integers(1, 700))
        part = stream[seq : seq + n]
        w.update(seq, float(seq), part, -part)
        seq += part.size
        op, pv = w.get()
        expected = stream[max(0, seq - 300) : seq].astype(np.float32)  # held as float32
        np.testing.assert_array_equal(op, expected)
        np.testing.assert_array_equal(pv, -expected)
        assert w.t_end_s == seq - 1 and w.next_seq == seq
    assert w.snapshot()["count"] == 300
    assert w.holds(seq - 10, stream[seq - 10 : seq], -stream[seq - 10 : seq])  # a repeat of float64 samples is seen
