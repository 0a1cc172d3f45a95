"""The plant-like loops' labels say what their simulated valves do."""

import numpy as np

from stiction.sim.loop import build_batch, run_batch
from stiction.sim.plant_loops import plant_loops


def test_a_sticky_plant_loops_band_is_the_gap_its_stem_breaks_at():
    """The stem breaks away when the drive is fs/12 from it: (S + J)/2 in Choudhury's terms, % of span."""
    loops = [loop for loop in plant_loops(6, 11) if loop.cause == "stiction"]
    w = np.zeros((len(loops), 3000))
    op, _, mv = run_batch(build_batch([loop.spec for loop in loops]), w, np.zeros_like(w))
    for i, loop in enumerate(loops):
        moving = np.abs(np.diff(mv[i])) > 1e-6
        breaks = np.flatnonzero(moving[1:] & ~moving[:-1]) + 1
        assert breaks.size >= 3
        gap = np.median(np.abs(op[i, breaks] - mv[i, breaks]))
        static = (loop.s_pct + loop.j_pct) / 2
        assert gap == np.clip(gap, 0.97 * static, 1.05 * static), (static, gap)
        assert 0 < loop.j_pct < loop.s_pct
