import numpy as np
import pytest

from stiction.quantify.acf import acf_period, autocorrelation
from stiction.sim.grid import case_specs
from stiction.sim.loop import simulate


def _direct_acf(y, max_lag):
    """Thesis 4.5 written out: c_k = 1/(N-1) sum (y_t - ybar)(y_{t+k} - ybar), r_k = c_k / c_0."""
    n, ybar = y.size, y.mean()
    c = [np.sum((y[: n - k] - ybar) * (y[k:] - ybar)) / (n - 1) for k in range(max_lag + 1)]
    return np.array(c) / c[0]


def test_fft_autocorrelation_matches_the_direct_sum():
    y = np.random.default_rng(0).normal(size=(3, 257)).cumsum(axis=1)
    fast = autocorrelation(y, 100)
    for i in range(3):
        np.testing.assert_allclose(fast[i], _direct_acf(y[i], 100), atol=1e-12)


@pytest.mark.parametrize("period", [17.3, 48.0, 140.5])
def test_period_of_a_noisy_sine(period):
    t = np.arange(1000.0)
    rng = np.random.default_rng(1)
    x = np.sin(2 * np.pi * t / period) + 0.3 * rng.normal(size=t.size)
    found, height = acf_period(x)
    assert found[0] == pytest.approx(period, rel=0.02)
    assert 0.5 < height[0] <= 1


def test_period_of_simulated_loops_matches_their_mean_crossings():
    specs = list(case_specs().values())[:10]  # noise-free
    r = simulate(specs).kept()
    periods, _ = acf_period(r.op)
    for i, spec in enumerate(specs):
        centred = r.op[i] - r.op[i].mean()
        ups = np.flatnonzero((centred[:-1] < 0) & (centred[1:] >= 0))
        assert periods[i] == pytest.approx(np.diff(ups).mean(), rel=0.05), spec


def test_no_period_in_white_noise_or_a_flat_line():
    rng = np.random.default_rng(2)
    p, h = acf_period(np.vstack([rng.normal(size=1000), np.zeros(1000)]))
    assert np.isnan(p[1])
    assert np.isnan(p[0]) or h[0] < 0.2
