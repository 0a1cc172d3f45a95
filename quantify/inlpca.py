"""Inverse nonlinear PCA with a circular bottleneck (thesis 3.4, Scholz 2005), batched over windows.

The inverse network maps one angle per sample through a circular unit
``(cos t_n, sin t_n)``, a hidden ``tanh`` layer and a linear output to the
sample's ``(OP, PV)``.  The angles are free parameters fitted together with the
weights, so a fitted window gives a closed curve (the network over all angles)
and every sample's own projection onto it (the network at the sample's angle).

Fitted here with analytic gradients and Adam in numpy, all windows of a batch at
once: no torch in the agent.  Each window is standardised on its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.quantify import inlpca_kernel


@dataclass(frozen=True)
class InlpcaSettings:
    hidden_units: int = 6
    iterations: int = 100
    fit_samples: int = 128
    """The curve is fitted on this many evenly spaced samples; all samples are then projected."""
    curve_points: int = 128
    learning_rate: float = 0.03
    angle_learning_rate: float = 0.1
    weight_decay: float = 1e-3
    seed: int = 0


DEFAULT_SETTINGS = InlpcaSettings()


@dataclass(frozen=True)
class InlpcaFit:
    """Fitted curves of a batch; shapes in brackets, W windows, N samples."""

    angles: np.ndarray  # [W, N] each sample's angle on its curve, unwrapped
    travel: np.ndarray  # [W] +1 or -1: the direction in which the loop goes round its curve
    denoised: np.ndarray  # [W, N, 2] each sample's projection onto the curve, (op, pv) units
    residual_rms: np.ndarray  # [W, 2] rms of data - projection, (op, pv) units
    explained: np.ndarray  # [W] 1 - residual variance / variance (standardised)
    _params: tuple

    def curve(self, angles: np.ndarray) -> np.ndarray:
        """The fitted curves at ``angles`` [W, M] -> [W, M, 2] in (op, pv) units."""
        w1, b1, w2, b2, mean, scale = self._params
        return _forward(angles, w1, b1, w2, b2)[0] * scale[:, None, :] + mean[:, None, :]


def _forward(theta, w1, b1, w2, b2):
    c, s = np.cos(theta), np.sin(theta)  # [W, N]
    a = c[..., None] * w1[:, None, :, 0] + s[..., None] * w1[:, None, :, 1] + b1[:, None, :]  # [W, N, H]
    h = np.tanh(a)
    out = h @ w2.transpose(0, 2, 1) + b2[:, None, :]  # [W, N, 2]
    return out, h, c, s


def loss_and_grads(theta, w1, b1, w2, b2, x, weight_decay):
    """Per-window loss ``mean_n |net(theta_n) - x_n|^2 / 2 + decay (|W1|^2 + |W2|^2) / 2`` and its gradients."""
    n = x.shape[1]
    out, h, c, s = _forward(theta, w1, b1, w2, b2)
    e = (out - x) / n  # [W, N, 2]
    loss = 0.5 * np.sum((out - x) ** 2, axis=(1, 2)) / n
    loss = loss + 0.5 * weight_decay * (np.sum(w1**2, axis=(1, 2)) + np.sum(w2**2, axis=(1, 2)))
    g_w2 = e.transpose(0, 2, 1) @ h + weight_decay * w2
    g_b2 = e.sum(axis=1)
    da = (e @ w2) * (1 - h * h)  # [W, N, H]
    g_w1 = np.stack([(c[:, None, :] @ da)[:, 0], (s[:, None, :] @ da)[:, 0]], axis=-1) + weight_decay * w1
    g_b1 = da.sum(axis=1)
    g_theta = -s * (da @ w1[..., 0:1])[..., 0] + c * (da @ w1[..., 1:2])[..., 0]
    return loss, (g_theta, g_w1, g_b1, g_w2, g_b2)


class _Adam:
    def __init__(self, shapes, lrs, b1=0.9, b2=0.999, eps=1e-8):
        self.m = [np.zeros(s) for s in shapes]
        self.v = [np.zeros(s) for s in shapes]
        self.lrs, self.b1, self.b2, self.eps, self.t = lrs, b1, b2, eps, 0

    def step(self, params, grads):
        self.t += 1
        out = []
        for i, (p, g) in enumerate(zip(params, grads, strict=True)):
            self.m[i] = self.b1 * self.m[i] + (1 - self.b1) * g
            self.v[i] = self.b2 * self.v[i] + (1 - self.b2) * g * g
            m_hat = self.m[i] / (1 - self.b1**self.t)
            v_hat = self.v[i] / (1 - self.b2**self.t)
            out.append(p - self.lrs[i] * m_hat / (np.sqrt(v_hat) + self.eps))
        return out


def _train_numpy(theta, w1, b1, w2, b2, x, iterations, lr, angle_lr, weight_decay) -> None:
    """The training loop in numpy, all windows at once, in place: the reference the compiled one
    (``quantify.inlpca_kernel.train``) is tested against."""
    n = x.shape[1]
    adam = _Adam([theta.shape, w1.shape, b1.shape, w2.shape, b2.shape], [angle_lr, lr, lr, lr, lr])
    params = [theta, w1, b1, w2, b2]
    for _ in range(iterations):
        _, (g_theta, g_w1, g_b1, g_w2, g_b2) = loss_and_grads(*params, x, weight_decay)
        # each angle moves only its own sample: scale its gradient back up to that sample's own loss
        params = adam.step(params, [g_theta * n, g_w1, g_b1, g_w2, g_b2])
    for target, value in zip((theta, w1, b1, w2, b2), params, strict=True):
        target[...] = value


def _initial_angles(x: np.ndarray) -> np.ndarray:
    """Angle of each standardised sample in its window's whitened principal plane."""
    cov = (x.transpose(0, 2, 1) @ x) / x.shape[1]
    evals, evecs = np.linalg.eigh(cov)
    z = (x @ evecs) / np.sqrt(np.maximum(evals, 1e-12))[:, None, :]
    return np.arctan2(z[..., 0], z[..., 1])


CHUNK_WINDOWS = 50
"""Windows fitted together: larger batches are memory-bound.  Batched products are matmul, not
einsum: for these small inner dimensions einsum was 10-20x slower."""


def warm_up() -> None:
    """Compile (or load from its cache) the training loop now, not in the first report's time: the
    first compile on a machine takes a few seconds."""
    t = np.arange(32, dtype=float)  # a tiny window and one iteration: only the compile costs
    fit(np.sin(t / 5)[None], np.cos(t / 5)[None], InlpcaSettings(iterations=1, fit_samples=16, curve_points=16))


def fit(
    op: np.ndarray, pv: np.ndarray, settings: InlpcaSettings = DEFAULT_SETTINGS, reference: bool = False
) -> InlpcaFit:
    """Fit one curve per row of ``op``, ``pv`` [W, N]; every sample is projected onto its curve.
    ``reference``: train with the numpy loop instead of the compiled one (the tests' reference)."""
    op, pv = np.atleast_2d(op), np.atleast_2d(pv)
    if op.shape[0] <= CHUNK_WINDOWS:
        return _fit_chunk(op, pv, settings, reference)
    parts = [
        _fit_chunk(op[i : i + CHUNK_WINDOWS], pv[i : i + CHUNK_WINDOWS], settings, reference)
        for i in range(0, op.shape[0], CHUNK_WINDOWS)
    ]
    return InlpcaFit(
        angles=np.concatenate([p.angles for p in parts]),
        travel=np.concatenate([p.travel for p in parts]),
        denoised=np.concatenate([p.denoised for p in parts]),
        residual_rms=np.concatenate([p.residual_rms for p in parts]),
        explained=np.concatenate([p.explained for p in parts]),
        _params=tuple(np.concatenate([p._params[j] for p in parts]) for j in range(len(parts[0]._params))),
    )


def _nearest(x: np.ndarray, curve: np.ndarray) -> np.ndarray:
    """Index of the curve point nearest to each sample: x [W, N, 2], curve [W, M, 2] -> [W, N] (compiled)."""
    return inlpca_kernel.nearest(np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(curve, dtype=float))


def _fit_chunk(op: np.ndarray, pv: np.ndarray, settings: InlpcaSettings, reference: bool = False) -> InlpcaFit:
    data = np.stack([np.atleast_2d(op), np.atleast_2d(pv)], axis=-1).astype(float)  # [W, N, 2]
    n_win, n_all = data.shape[:2]
    mean = data.mean(axis=1)
    scale = data.std(axis=1)
    scale = np.where(scale > 1e-12, scale, 1.0)
    x_all = (data - mean[:, None, :]) / scale[:, None, :]
    pick = np.unique(np.linspace(0, n_all - 1, min(settings.fit_samples, n_all)).round().astype(int))
    x = x_all[:, pick]
    n = x.shape[1]
    rng = np.random.default_rng(settings.seed)
    hidden = settings.hidden_units
    theta = _initial_angles(x)
    w1 = np.broadcast_to(rng.normal(0, 1.0, (hidden, 2)), (n_win, hidden, 2)).copy()
    b1 = np.broadcast_to(rng.normal(0, 0.3, hidden), (n_win, hidden)).copy()
    # output layer: least squares on the initial hidden activations
    _, h, _, _ = _forward(theta, w1, b1, np.zeros((n_win, 2, hidden)), np.zeros((n_win, 2)))
    h1 = np.concatenate([h, np.ones((n_win, n, 1))], axis=2)
    gram = h1.transpose(0, 2, 1) @ h1 + 1e-6 * np.eye(hidden + 1)
    sol = np.linalg.solve(gram, h1.transpose(0, 2, 1) @ x)  # [W, H+1, 2]
    w2, b2 = np.transpose(sol[:, :hidden, :], (0, 2, 1)).copy(), sol[:, hidden, :].copy()

    theta, w1, b1, w2, b2 = (np.ascontiguousarray(a, dtype=float) for a in (theta, w1, b1, w2, b2))
    train = _train_numpy if reference else inlpca_kernel.train
    train(theta, w1, b1, w2, b2, np.ascontiguousarray(x), settings.iterations, settings.learning_rate,
          settings.angle_learning_rate, settings.weight_decay)  # fmt: skip

    # every sample: nearest point of the densely sampled curve (standardised units)
    grid = np.linspace(-np.pi, np.pi, settings.curve_points, endpoint=False)
    curve = _forward(np.broadcast_to(grid, (n_win, grid.size)), w1, b1, w2, b2)[0]  # [W, M, 2]
    nearest = _nearest(x_all, curve)  # [W, N]
    theta_all = grid[nearest]
    out = np.take_along_axis(curve, nearest[..., None], axis=1)
    resid = x_all - out
    explained = 1 - np.mean(resid**2, axis=(1, 2)) / np.mean(x_all**2, axis=(1, 2))
    unwrapped = np.unwrap(theta_all, axis=1)
    travel = np.sign(unwrapped[:, -1] - unwrapped[:, 0])
    travel = np.where(travel == 0, 1.0, travel)
    return InlpcaFit(
        angles=unwrapped,
        travel=travel,
        denoised=out * scale[:, None, :] + mean[:, None, :],
        residual_rms=np.sqrt(np.mean(resid**2, axis=1)) * scale,
        explained=explained,
        _params=(w1, b1, w2, b2, mean, scale),
    )


def no_fit(shape: tuple[int, int], settings: InlpcaSettings = DEFAULT_SETTINGS) -> InlpcaFit:
    """An all-nan fit of ``shape`` (windows, samples): the place of windows left unfitted in a batch."""
    n, m = shape
    h = settings.hidden_units
    nan = np.nan
    params = (
        np.full((n, h, 2), nan), np.full((n, h), nan), np.full((n, 2, h), nan), np.full((n, 2), nan),
        np.full((n, 2), nan), np.full((n, 2), nan),
    )  # fmt: skip
    return InlpcaFit(
        np.full((n, m), nan), np.ones(n), np.full((n, m, 2), nan), np.full((n, 2), nan), np.full(n, nan), params
    )
