"""A cycle longer than any trained on is read thinned (``detect.thinning``)."""

from dataclasses import replace

import numpy as np

from stiction.detect.thinning import LONGEST_PERIOD_SAMPLES, TYPICAL_PERIOD_SAMPLES, thinned, verdict_steps


def test_the_step_brings_a_long_cycle_to_a_typical_one_and_keeps_a_window():
    periods = np.array([0.0, np.nan, 120.0, LONGEST_PERIOD_SAMPLES, 400.0, 900.0, 5000.0])
    steps = verdict_steps(periods, 3600)
    assert steps.tolist() == [1, 1, 1, 1, round(400 / TYPICAL_PERIOD_SAMPLES), 6, 6]  # 900 / 63: 14, but 600 kept
    assert verdict_steps(periods, 1000).tolist() == [1] * 7  # an agent's window: too short to thin
    assert verdict_steps(periods, 1800).max() == 3  # 600 samples kept
    assert thinned(np.arange(10), 3).tolist() == [0, 3, 6, 9]
    assert thinned(np.arange(11), 3).tolist() == [1, 4, 7, 10]  # the newest sample kept
    assert thinned(np.arange(22).reshape(2, 11), 5).tolist() == [[0, 5, 10], [11, 16, 21]]


def test_an_upstream_loops_slow_square_cycle_recorded_fast_is_left_alone():
    """Hidden effect: the cycle's length in samples.  The independent simulator's loops (``sim.two_parameter``,
    design seed 3234) recorded four times faster than it draws them: an external square-wave load cycling every
    300-1,700 samples.  Read at every sample, 8 of those 25 healthy valves were called sticky (the window network's
    chunks held less than two cycles); read thinned, 1.  The sticky valves' long limit cycles are called as before
    (10 of 11)."""
    from stiction.detect.features import evidence
    from stiction.quantify.pipeline import Quantifier
    from stiction.quantify.window import Window
    from stiction.sim import two_parameter
    from stiction.sim.plant_families import stable

    loops = [replace(loop, ts_s=loop.ts_s / 4) for loop in two_parameter.draw(40, 3234)
             if loop.cause in ("square", "stiction")]  # fmt: skip
    windows, causes = [], []
    for loop, rec in zip(loops, two_parameter.simulate(loops, 8000), strict=True):
        o, p, s = rec.op[-3600:], rec.pv[-3600:], rec.sp[-3600:]
        osc = evidence(o, p, rec.ts_s, s).oscillation
        longer = osc.oscillating and osc.period_s / rec.ts_s > 300  # than a training window's two cycles
        if stable(rec) and longer and (loop.cause == "square" or rec.shows_fault):
            windows.append(Window(f"w{len(windows)}", o, p, rec.ts_s, sp=s))
            causes.append(loop.cause)
    reports = Quantifier(fit_valve=False).quantify(windows)
    square = [r for r, c in zip(reports, causes, strict=True) if c == "square"]
    sticky = [r for r, c in zip(reports, causes, strict=True) if c == "stiction"]
    assert len(square) >= 20 and len(sticky) >= 8
    assert sum(r.verdict == "stiction" for r in square) <= 3
    assert sum(r.verdict == "stiction" for r in sticky) >= len(sticky) - 2
    assert all("one sample in" in " ".join(r.warnings) for r in square)
