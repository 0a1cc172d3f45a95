"""Simulator benchmark: the 1275-pattern grid, and the same loops with the ODE reference."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from stiction.sim.grid import case_specs, training_specs
from stiction.sim.loop import LoopState, advance, build_batch, disturbance_signals, simulate
from stiction.sim.reference import IN_PER_PCT, RefState, reference_interval, reference_simulate
from stiction.sim.valve import pct_to_lbf


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


def interval_agreement(spec, intervals: int = 220) -> tuple[float, float, int]:
    """The spec's integrator check for one loop: restarted from the reference's state at every sample
    and advanced one sample with the same OP and disturbance, the worst |MV| and |PV| differences [%]
    over ``intervals`` samples of the limit cycle, and how many of them held a slip.
    """
    batch = build_batch([spec])
    clean = simulate([replace(spec, disturbance=None)], duration_s=1000.0 + intervals)
    w, z = disturbance_signals([spec], clean.t_s, clean)
    # the fast simulator's own state at sample 1000 seeds the reference on the limit cycle
    state = LoopState.at_rest(batch)
    for k in range(1000):
        state, _, _ = advance(batch, state, w[:, k], z[:, k])
    ref = RefState(state.mv[0] * IN_PER_PCT, 0.0, state.x[0, 0])
    error_sum = state.error_sum.copy()
    fs_lbf, fd_lbf = float(pct_to_lbf(spec.fs_pct)), float(pct_to_lbf(spec.fd_pct))
    worst_mv = worst_pv = 0.0
    slips = 0
    for k in range(1000, 1000 + intervals):
        fast_from_ref = LoopState(
            np.array([[ref.y_pct, 0.0]]),
            error_sum,
            np.array([ref.x_in / IN_PER_PCT]),
            state.drive,
            state.played,
            state.flow_hist,
            k,
        )
        fast_next, op, _ = advance(batch, fast_from_ref, w[:, k], z[:, k])
        ref_next = reference_interval(ref, float(op[0]), float(w[0, k]), fs_lbf, fd_lbf)
        if abs(ref_next.v_in_s) > 1e-6:
            raise RuntimeError(f"reference stem still moving at sample {k}")
        mv_ref = ref_next.x_in / IN_PER_PCT
        slips += abs(mv_ref - ref.x_in / IN_PER_PCT) > 1e-9
        worst_mv = max(worst_mv, abs(fast_next.mv[0] - mv_ref))
        worst_pv = max(worst_pv, abs(fast_next.x[0, 0] - ref_next.y_pct))
        ref, error_sum = ref_next, fast_next.error_sum
    return worst_mv, worst_pv, slips


def bench_agreement(intervals: int = 220) -> dict:
    """``interval_agreement`` over the 20 test cases: the figures the spec asks for."""
    rows = {name: interval_agreement(spec, intervals) for name, spec in case_specs().items()}
    return {
        "intervals_per_case": intervals,
        "worst_mv_diff_pct": max(r[0] for r in rows.values()),
        "worst_pv_diff_pct": max(r[1] for r in rows.values()),
        "min_slips_per_case": min(r[2] for r in rows.values()),
        "per_case": {n: {"mv_diff_pct": r[0], "pv_diff_pct": r[1], "slips": r[2]} for n, r in rows.items()},
    }


def print_table(figures: dict) -> None:
    """The figures as text (``repeats`` and ``reference_loops``: the run's settings, in the figures)."""
    print(f"grid: {figures['loops']} loops x {figures['duration_s']:.0f} s, physical valve, one core")
    print(
        f"  fast simulator     {figures['grid_s']:8.2f} s  ({figures['grid_loops_per_s']:.0f} loops/s,"
        f" median of {figures['repeats']})"
    )
    print(
        f"  ODE reference      {figures['reference_s']:8.0f} s  ({figures['reference_s_per_loop']:.1f} s/loop"
        f" over {figures['reference_loops']} grid points, extrapolated)"
    )
    print(
        f"  speedup            {figures['speedup']:8.0f} x  (same loops one at a time:"
        f" {figures['speedup_single_loop']:.0f} x)"
    )
    if "agreement" in figures:
        a = figures["agreement"]
        print(
            f"  one interval from the reference's state, 20 test cases x {a['intervals_per_case']} samples:"
            f" worst MV difference {a['worst_mv_diff_pct']:.1e} % of span (spec: < 0.05 %),"
            f" worst PV difference {a['worst_pv_diff_pct']:.1e} %, >= {a['min_slips_per_case']} slips a case"
        )
