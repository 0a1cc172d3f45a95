import math

import numpy as np
import pytest

from stiction.quantify import inlpca


def test_analytic_gradients_match_finite_differences():
    rng = np.random.default_rng(0)
    w, n, h = 2, 15, 4
    params = [
        rng.normal(size=(w, n)),
        rng.normal(size=(w, h, 2)),
        rng.normal(size=(w, h)),
        rng.normal(size=(w, 2, h)),
        rng.normal(size=(w, 2)),
    ]
    x = rng.normal(size=(w, n, 2))
    _, grads = inlpca.loss_and_grads(*params, x, 0.01)
    eps = 1e-6
    for p, g in zip(params, grads, strict=True):
        for idx in [(0,) + tuple(0 for _ in p.shape[1:]), (1,) + tuple(s - 1 for s in p.shape[1:])]:
            old = p[idx]
            p[idx] = old + eps
            up, _ = inlpca.loss_and_grads(*params, x, 0.01)
            p[idx] = old - eps
            down, _ = inlpca.loss_and_grads(*params, x, 0.01)
            p[idx] = old
            assert g[idx] == pytest.approx((up[idx[0]] - down[idx[0]]) / (2 * eps), rel=1e-5, abs=1e-9)


def _true_curve(phase):
    """A lopsided closed curve like a stiction OP-PV loop."""
    return np.stack([8 * np.sin(phase) + 1.5 * np.sin(2 * phase), 3 * np.cos(phase) + 0.5 * np.cos(3 * phase)], -1)


def _distance_to_true_curve(points):
    dense = _true_curve(np.linspace(0, 2 * np.pi, 4000, endpoint=False))
    return np.sqrt(np.min(np.sum((points[:, None, :] - dense[None]) ** 2, axis=2), axis=1))


def test_denoised_points_lie_closer_to_the_true_curve_than_the_noisy_ones():
    rng = np.random.default_rng(1)
    t = np.arange(1000.0)
    clean = np.stack([_true_curve(2 * np.pi * t / p + p) for p in (37.0, 90.0)])  # [2, N, 2]
    noisy = clean + rng.normal(0, 0.6, clean.shape)
    fit = inlpca.fit(noisy[..., 0], noisy[..., 1])
    for i in range(2):
        before = np.sqrt(np.mean(_distance_to_true_curve(noisy[i]) ** 2))
        after = np.sqrt(np.mean(_distance_to_true_curve(fit.denoised[i]) ** 2))
        assert after < 0.5 * before
        assert fit.explained[i] > 0.95


def test_angles_advance_with_time_in_one_direction():
    t = np.arange(600.0)
    period = 50.0
    clean = _true_curve(2 * np.pi * t / period)
    fit = inlpca.fit(clean[None, :, 0], clean[None, :, 1])
    turns = abs(fit.angles[0, -1] - fit.angles[0, 0]) / (2 * np.pi)
    assert turns == pytest.approx(600 / period, abs=1.0)
    steps = np.diff(fit.angles[0]) * fit.travel[0]
    assert np.mean(steps > 0) > 0.95


def test_blocked_projection_finds_the_nearest_curve_point_as_a_brute_force_search_does():
    from stiction.quantify.inlpca import _nearest

    rng = np.random.default_rng(2)
    x, curve = rng.normal(size=(23, 300, 2)), rng.normal(size=(23, 64, 2))  # not a multiple of the block
    brute = np.array([[np.argmin(np.hypot(*(c - p).T)) for p in xs] for xs, c in zip(x, curve, strict=True)])
    assert np.array_equal(_nearest(x, curve), brute)


def test_the_compiled_training_loop_follows_the_numpy_reference():
    rng = np.random.default_rng(3)
    t = np.arange(600)
    op = 50 + 10 * np.sign(np.sin(2 * np.pi * t / 90))[None] + rng.normal(0, 0.5, (5, 600))
    pv = 50 + 5 * np.sin(2 * np.pi * (t - 20) / 90)[None] + rng.normal(0, 0.5, (5, 600))
    fast = inlpca.fit(op, pv)
    slow = inlpca.fit(op, pv, reference=True)
    for a, b in zip(fast._params, slow._params, strict=True):
        np.testing.assert_allclose(a, b, atol=1e-7)
    np.testing.assert_allclose(fast.denoised, slow.denoised, atol=1e-6)
    one = inlpca.fit(op[2:3], pv[2:3])  # window by window: a window's fit does not depend on its batch
    np.testing.assert_array_equal(one._params[0][0], fast._params[0][2])


def test_the_training_loops_arithmetic_tanh_sine_and_cosine_follow_the_librarys():
    from stiction.quantify import inlpca_kernel as k

    # activations of either sign, well into saturation; angles of many turns either way, quadrant edges included
    for a in np.concatenate([np.linspace(-30, 30, 6001), [0.0, 1e-300, -1e-12, 19.9, 20.0, 20.1]]):
        assert abs(k._tanh(a) - math.tanh(a)) <= 1e-14, a
    turns = np.concatenate([np.linspace(-60, 60, 6001), np.arange(-40, 41) * np.pi / 4])
    for theta in turns:
        s, c = k._sin_cos(theta)
        assert abs(s - math.sin(theta)) <= 1e-14 and abs(c - math.cos(theta)) <= 1e-14, theta
