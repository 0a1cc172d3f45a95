"""The sampled loop: limit cycles, batching, disturbances."""

from dataclasses import replace

import numpy as np
import pytest

from stiction.sim.disturbance import Disturbance, kasdin_ar_coefficients, rms, unit_shape
from stiction.sim.grid import NOISY_CASES, case_specs, training_grid_lbf, training_specs
from stiction.sim.loop import LoopSpec, disturbance_signals, simulate
from stiction.sim.valve import VALVE, pct_to_lbf


@pytest.fixture(scope="module")
def grid():
    return simulate(training_specs()).kept()


def test_training_grid_is_the_thesis_loop():
    pairs = training_grid_lbf()
    assert len(pairs) == 1275
    assert pairs[0] == (500.0, 490.0) and pairs[49] == (500.0, 0.0) and pairs[-1] == (10.0, 0.0)
    assert all(0 <= fd < fs for fs, fd in pairs)


def _slip_counts(op, mv):
    moves = np.diff(mv, axis=1)
    return (moves > 0).sum(axis=1), (moves < 0).sum(axis=1)


def test_every_grid_point_sustains_a_limit_cycle(grid):
    """Both halves of the kept record slip both ways, with a steady amplitude (no decay, no drift)."""
    half = grid.op.shape[1] // 2
    failures = []
    for i, spec in enumerate(grid.specs):
        for part in (slice(0, half), slice(half, None)):
            up, down = _slip_counts(grid.op[i : i + 1, part], grid.mv[i : i + 1, part])
            if up[0] < 2 or down[0] < 2:
                failures.append((spec.fs_pct, spec.fd_pct, "fewer than 2 slips each way in 500 s"))
        a1 = np.ptp(grid.pv[i, :half])
        a2 = np.ptp(grid.pv[i, half:])
        if not 0.8 < a2 / a1 < 1.25:
            failures.append((spec.fs_pct, spec.fd_pct, f"PV amplitude changes {a1:.3g} -> {a2:.3g}"))
    assert failures == []


def test_stem_holds_between_slips_and_slips_only_past_the_band(grid):
    force_lbf = VALVE.lbf_per_pct * (grid.op[:, :-1] - grid.mv[:, :-1])
    fs_lbf = pct_to_lbf([s.fs_pct for s in grid.specs])[:, None]
    moved = grid.mv[:, 1:] != grid.mv[:, :-1]
    np.testing.assert_array_equal(moved, np.abs(force_lbf) > fs_lbf)


def test_batch_equals_loops_simulated_one_by_one():
    specs = [*case_specs(seed=4).values(), LoopSpec(30, 10, loop="concentration"), LoopSpec(30, 10, valve="he")]
    together = simulate(specs, duration_s=600)
    for i, spec in enumerate(specs):
        alone = simulate([spec], duration_s=600)
        np.testing.assert_allclose(together.op[i], alone.op[0], rtol=0, atol=1e-9)
        np.testing.assert_allclose(together.mv[i], alone.mv[0], rtol=0, atol=1e-9)


def _scalar_he_level_loop(fs_op, fd_op, n):
    """A plain transcription of the level loop with He's valve: integrator 1/(15 s), PI 3(1 + 1/(30 s))."""
    y = mv = error_sum = 0.0
    out = []
    for _ in range(n):
        pv = y
        error = 1.0 - pv
        error_sum += error
        op = 3.0 * (error + error_sum / 30.0)
        out.append((op, pv, mv))
        if abs(op - mv) > fs_op:
            mv = op - np.sign(op - mv) * fd_op
        y += mv / 15.0
    return np.array(out).T


def test_vectorised_loop_matches_scalar_transcription_with_he_valve():
    fs_pct, fd_pct = 40.0, 15.0
    result = simulate([LoopSpec(fs_pct, fd_pct, valve="he")], duration_s=400)
    op, pv, mv = _scalar_he_level_loop(pct_to_lbf(fs_pct) / 12, pct_to_lbf(fd_pct) / 12, 400)
    # chaos amplifies rounding differences by 30-100x per cycle; 400 s is a few cycles
    np.testing.assert_allclose(result.op[0], op, atol=1e-7)
    np.testing.assert_allclose(result.pv[0], pv, atol=1e-7)
    np.testing.assert_allclose(result.mv[0], mv, atol=1e-7)


def test_kasdin_alpha_two_is_a_random_walk():
    a = kasdin_ar_coefficients(2.0)
    assert a[0] == 1 and a[1] == -1 and np.all(a[2:] == 0)
    rng1, rng2 = np.random.default_rng(7), np.random.default_rng(7)
    shape = unit_shape("brownian", 2000, 1.0, rng1)
    walk = np.cumsum(rng2.standard_normal(2000))
    walk = (walk - walk.mean()) / walk.std()
    np.testing.assert_allclose(shape, walk, atol=1e-9)


@pytest.mark.parametrize("name", list(NOISY_CASES))
def test_disturbance_amplitude_is_relative_to_the_clean_loop(name):
    spec = case_specs(seed=11)[name]
    clean = simulate([replace(spec, disturbance=None)])
    w, z = disturbance_signals([spec], clean.t_s, clean)
    d = spec.disturbance
    kept = clean.t_s >= 1000
    reference = rms(clean.mv[0, kept]) if d.where == "input" else rms(clean.pv[0, kept])
    signal = (w if d.where == "input" else z)[0]
    assert not np.any((z if d.where == "input" else w)[0])
    if d.shape == "sine":  # sin(omega t) from phase zero, amplitude c * RMS
        np.testing.assert_allclose(signal, d.coefficient * reference * np.sin(d.omega_rad_s * clean.t_s))
    elif d.shape == "brownian":  # unit RMS over the whole record after removing the mean
        np.testing.assert_allclose(rms(signal), d.coefficient * reference, rtol=1e-9)
    else:  # white: unit RMS in expectation
        np.testing.assert_allclose(rms(signal), d.coefficient * reference, rtol=0.05)


def test_noisy_cases_are_reproducible_per_seed_and_differ_between_seeds():
    spec = case_specs()["N4"]
    a = simulate([replace(spec, seed=1)]).pv
    b = simulate([replace(spec, seed=1)]).pv
    c = simulate([replace(spec, seed=2)]).pv
    np.testing.assert_array_equal(a, b)
    assert np.abs(a - c).max() > 0.01


def test_bad_specs_are_rejected_with_a_reason():
    with pytest.raises(ValueError, match="fd_pct <= fs_pct"):
        LoopSpec(10.0, 20.0)
    with pytest.raises(ValueError, match="unknown loop"):
        LoopSpec(10.0, 5.0, loop="pressure")
    with pytest.raises(ValueError, match="finite"):
        LoopSpec(float("nan"), 5.0)
    with pytest.raises(ValueError, match="omega"):
        Disturbance("sine", "output", 0.1)
