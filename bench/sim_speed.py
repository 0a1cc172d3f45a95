"""Simulator benchmark: the 1275-pattern grid, and the same loops with the ODE reference."""

from __future__ import annotations

import time

import numpy as np

from sim.grid import training_specs
from sim.loop import simulate
from sim.reference import reference_simulate


def bench_sim(reference_loops: int = 3, duration_s: float = 2000.0, repeats: int = 3) -> dict:
    """Times on this process's one thread (``time.process_time``), medians over ``repeats``.

    The reference (``solve_ivp`` with stick/slip events, seconds per loop) runs on
    ``reference_loops`` grid points spread over the grid; the fast simulator is timed
    on the whole grid and, for a like-for-like ratio, on those same points one at a time.
    """
    specs = training_specs()
    grid_times = []
    for _ in range(repeats):
        started = time.process_time()
        simulate(specs, duration_s=duration_s)
        grid_times.append(time.process_time() - started)
    grid_s = float(np.median(grid_times))

    picks = np.linspace(0, len(specs) - 1, reference_loops).round().astype(int)
    ref_times, fast_times = [], []
    for i in picks:
        spec = specs[i]
        started = time.process_time()
        reference_simulate(spec.fs_pct, spec.fd_pct, duration_s)
        ref_times.append(time.process_time() - started)
        started = time.process_time()
        simulate([spec], duration_s=duration_s)
        fast_times.append(time.process_time() - started)
    ref_per_loop = float(np.mean(ref_times))
    reference_s = ref_per_loop * len(specs)
    return {
        "loops": len(specs),
        "duration_s": duration_s,
        "grid_s": grid_s,
        "grid_loops_per_s": len(specs) / grid_s,
        "reference_s": reference_s,
        "reference_s_is_extrapolated_from_loops": int(reference_loops),
        "reference_s_per_loop": ref_per_loop,
        "fast_single_loop_s": float(np.mean(fast_times)),
        "speedup": reference_s / grid_s,
        "speedup_single_loop": ref_per_loop / float(np.mean(fast_times)),
    }
