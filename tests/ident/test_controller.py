"""The PI controller read off a loop's record, and the thesis's loop recognised by it."""

import numpy as np
import pytest

from stiction.ident.controller import MIN_EXPLAINED, fit_pi, matches
from stiction.sim.grid import case_specs, random_loops
from stiction.sim.loop import simulate
from stiction.sim.plant_loops import plant_loops, simulate_plant, stable
from stiction.sim.process import LOOPS


def _plant(n_per_class, seed):
    loops = plant_loops(n_per_class, seed)
    return [(loop, rec) for loop, rec in zip(loops, simulate_plant(loops), strict=True) if stable(rec[0], rec[1])]


def test_the_fit_reads_each_plant_loops_own_kc_and_ti():
    # recorded every second (the PI's own interval) and not rounded: the PI explains OP exactly
    loops = [(loop, rec) for loop, rec in _plant(10, 41) if loop.every == 1 and loop.cause != "quantization"]
    assert len(loops) >= 5
    for loop, (op, pv, sp, ts_s) in loops:
        fit = fit_pi(op, pv, ts_s, [sp])
        assert fit.explained[0] >= MIN_EXPLAINED
        assert fit.kc[0] == pytest.approx(loop.spec.process.controller_gain, rel=1e-3)
        assert fit.ti_s[0] == pytest.approx(loop.spec.process.integral_time_s, rel=1e-3)


def test_without_a_setpoint_a_constant_one_is_assumed():
    r = simulate(list(case_specs(seed=3).values())[:12]).kept()
    canonical = LOOPS["level"]
    with_sp, without = fit_pi(r.op, r.pv, 1.0, list(r.sp)), fit_pi(r.op, r.pv, 1.0)
    np.testing.assert_allclose(with_sp.kc, canonical.controller_gain, rtol=1e-6)
    np.testing.assert_allclose(without.ti_s, canonical.integral_time_s, rtol=1e-6)


def test_the_thesis_loop_matches_and_no_plant_like_loop_does():
    canonical = LOOPS["level"]
    r = simulate(random_loops(20, 77)).kept()
    assert matches(fit_pi(r.op, r.pv, 1.0), canonical.controller_gain, canonical.integral_time_s).all()
    for _loop, (op, pv, sp, ts_s) in _plant(8, 43):
        for sps in ([sp], None):
            assert not matches(fit_pi(op, pv, ts_s, sps), canonical.controller_gain, canonical.integral_time_s)[0]


def test_a_record_the_pi_does_not_explain_is_not_read_as_a_match():
    canonical = LOOPS["level"]
    r = simulate(random_loops(4, 78)).kept()
    rng = np.random.default_rng(0)
    op = r.op + rng.standard_normal(r.op.shape) * np.std(r.op) * 0.1  # moves the controller never made
    fit = fit_pi(op, r.pv, 1.0)
    assert (fit.explained < MIN_EXPLAINED).all()
    assert not matches(fit, canonical.controller_gain, canonical.integral_time_s).any()
    flat = fit_pi(np.ones((1, 300)), np.ones((1, 300)))
    assert np.isnan(flat.kc[0]) and not matches(flat, 3.0, 30.0)[0]


def _reference(op, pv, ts_s, sp=None):
    """numpy's least squares on the same four columns."""
    n = op.size
    e = (sp if sp is not None else 0.0) - pv
    x = np.stack([np.ones(n), np.arange(n) / n, e, np.cumsum(e) * ts_s], axis=1)
    scale = np.linalg.norm(x, axis=0)
    c, *_ = np.linalg.lstsq(x / scale, op, rcond=None)
    c /= scale
    r = op - x @ c
    return c[2], c[2] / c[3], 1 - np.var(r) / np.var(op)


def test_the_compiled_fit_equals_numpys_least_squares():
    records = [rec for _, rec in _plant(3, 44)]
    r = simulate(random_loops(6, 79)).kept()
    records += [(r.op[i], r.pv[i], r.sp[i], 1.0) for i in range(r.op.shape[0])]
    for op, pv, sp, ts_s in records:
        for sps in ([sp], None):
            fit = fit_pi(op, pv, ts_s, sps)
            kc, ti, explained = _reference(op, pv, ts_s, None if sps is None else sp)
            assert fit.kc[0] == pytest.approx(kc, rel=1e-6, abs=1e-9)
            assert fit.ti_s[0] == pytest.approx(ti, rel=1e-6)
            assert fit.explained[0] == pytest.approx(explained, abs=1e-9)
