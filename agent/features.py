"""What the predictors see: the thesis' OP window, the rebuilt OP, and cycle features.

- ``thesis_window``: 100 samples of OP from the start of the first cycle (thesis 4.6,
  Figure 4.9), the start being OP's first upward crossing of its mean.
- ``rebuilt_op``: the thesis' clean OP(t) for a noisy loop: walk round the INLPCA
  curve at uniform speed, one turn per ACF period, from the cycle start (thesis 4.4-4.5).
- ``cycle_features``: the average cycle over the whole window: the INLPCA curve at
  ``CURVE_POINTS`` angles from OP's maximum in the direction of travel, the share of time
  the samples' own projections spend near each of those angles (so timing is kept,
  not assumed uniform), and the period.
"""

from __future__ import annotations

import numpy as np

from agent.inlpca import InlpcaFit

THESIS_WINDOW = 100
CURVE_POINTS = 32
CYCLE_FEATURES = 3 * CURVE_POINTS + 1


def first_cycle_start(op: np.ndarray) -> np.ndarray:
    """Index of each row's first upward crossing of its mean (or 0 if there is none)."""
    centred = op - op.mean(axis=1, keepdims=True)
    up = (centred[:, :-1] < 0) & (centred[:, 1:] >= 0)
    has = up.any(axis=1)
    return np.where(has, np.argmax(up, axis=1) + 1, 0)


def thesis_window(op: np.ndarray, length: int = THESIS_WINDOW) -> np.ndarray:
    """[W, length] OP from the first cycle start; rows too short for it are ``nan``."""
    op = np.atleast_2d(op)
    start = first_cycle_start(op)
    out = np.full((op.shape[0], length), np.nan)
    for i, s in enumerate(start):
        seg = op[i, s : s + length]
        out[i, : seg.size] = seg
    return out


def _angle_of_max_op(fit: InlpcaFit) -> tuple[np.ndarray, np.ndarray]:
    grid = np.linspace(-np.pi, np.pi, 256, endpoint=False)
    curve = fit.curve(np.broadcast_to(grid, (fit.travel.size, grid.size)))
    return grid[np.argmax(curve[..., 0], axis=1)], curve


def rebuilt_op(fit: InlpcaFit, period_s: np.ndarray, ts_s: float = 1.0, length: int = THESIS_WINDOW) -> np.ndarray:
    """The thesis' reconstruction: OP along the curve at uniform angular speed, from the cycle start."""
    grid = np.linspace(-np.pi, np.pi, 256, endpoint=False)
    curve = fit.curve(np.broadcast_to(grid, (fit.travel.size, grid.size)))
    op_curve = curve[..., 0]
    centred = op_curve - op_curve.mean(axis=1, keepdims=True)
    out = np.full((fit.travel.size, length), np.nan)
    t = np.arange(length) * ts_s
    for i in range(fit.travel.size):
        if not np.isfinite(period_s[i]):
            continue
        ordered = centred[i] if fit.travel[i] > 0 else centred[i, ::-1]
        angles = grid if fit.travel[i] > 0 else grid[::-1]
        up = np.flatnonzero((ordered < 0) & (np.roll(ordered, -1) >= 0))
        start = angles[(up[0] + 1) % grid.size] if up.size else angles[0]
        walk = start + fit.travel[i] * 2 * np.pi * t / period_s[i]
        out[i] = fit.curve(walk[None, :])[0, :, 0] if fit.travel.size == 1 else _curve_row(fit, i, walk)
    return out


def _curve_row(fit: InlpcaFit, i: int, angles: np.ndarray) -> np.ndarray:
    full = np.zeros((fit.travel.size, angles.size))
    full[i] = angles
    return fit.curve(full)[i, :, 0]


def cycle_features(fit: InlpcaFit, period_s: np.ndarray) -> np.ndarray:
    """[W, CYCLE_FEATURES]: curve OP and PV (mean removed from PV), time shares, period."""
    n_win = fit.travel.size
    start, _ = _angle_of_max_op(fit)
    steps = np.arange(CURVE_POINTS) * 2 * np.pi / CURVE_POINTS
    angles = start[:, None] + fit.travel[:, None] * steps[None, :]
    curve = fit.curve(angles)  # [W, P, 2]
    op_c = curve[..., 0]
    pv_c = curve[..., 1] - curve[..., 1].mean(axis=1, keepdims=True)
    # share of samples whose projection falls in each angular bin, counted from the start
    rel = np.mod((fit.angles - start[:, None]) * fit.travel[:, None], 2 * np.pi)
    bins = np.minimum((rel / (2 * np.pi) * CURVE_POINTS).astype(int), CURVE_POINTS - 1)
    share = np.zeros((n_win, CURVE_POINTS))
    np.add.at(share, (np.repeat(np.arange(n_win), bins.shape[1]), bins.ravel()), 1.0)
    share /= bins.shape[1]
    return np.concatenate([op_c, pv_c, share * CURVE_POINTS, np.asarray(period_s)[:, None]], axis=1)
