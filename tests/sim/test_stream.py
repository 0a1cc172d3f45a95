"""The streamed loops are the batch simulator's, sample for sample, over its 2000 s."""

import numpy as np

from stiction.sim.extensions import Extensions
from stiction.sim.grid import case_specs
from stiction.sim.loop import LoopSpec, simulate
from stiction.sim.stream import LoopStream


def test_stream_equals_simulate_chunk_by_chunk():
    specs = [
        *case_specs(seed=4).values(),
        LoopSpec(30, 10, extensions=Extensions(osc_period_s=23, osc_amplitude_pct=1)),
    ]
    stream = LoopStream(specs)
    chunks = [stream.next(n) for n in (700, 900, 400, 500)]
    op = np.concatenate([c.op for c in chunks], axis=1)
    pv = np.concatenate([c.pv for c in chunks], axis=1)
    ref = simulate(specs)
    np.testing.assert_array_equal(op[:, :2000], ref.op)
    np.testing.assert_array_equal(pv[:, :2000], ref.pv)
    assert [c.seq for c in chunks] == [0, 700, 1600, 2000] and np.all(np.isfinite(op[:, 2000:]))
