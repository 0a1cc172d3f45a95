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

from stiction.quantify.inlpca import InlpcaFit

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


def _angle_of_max_op(fit: InlpcaFit) -> np.ndarray:
    grid = np.linspace(-np.pi, np.pi, 256, endpoint=False)
    curve = fit.curve(np.broadcast_to(grid, (fit.travel.size, grid.size)))
    return grid[np.argmax(curve[..., 0], axis=1)]


def rebuilt_op(fit: InlpcaFit, period_s: np.ndarray, ts_s: float = 1.0, length: int = THESIS_WINDOW) -> np.ndarray:
    """The thesis' reconstruction: OP along the curve at uniform angular speed, from the cycle start.

    The start is where the curve's OP crosses its mean upwards, going round in the
    direction of travel; rows without a period are ``nan``.
    """
    n_win = fit.travel.size
    grid = np.linspace(-np.pi, np.pi, 256, endpoint=False)
    op_curve = fit.curve(np.broadcast_to(grid, (n_win, grid.size)))[..., 0]
    # the curve in its direction of travel: angle increments of travel * 2 pi / 256
    order = np.where(fit.travel[:, None] > 0, np.arange(grid.size), np.arange(grid.size)[::-1])
    ordered = np.take_along_axis(op_curve - op_curve.mean(axis=1, keepdims=True), order, axis=1)
    up = (ordered < 0) & (np.roll(ordered, -1, axis=1) >= 0)
    first = np.where(up.any(axis=1), (np.argmax(up, axis=1) + 1) % grid.size, 0)
    start = grid[order[np.arange(n_win), first]]
    period = np.where(np.isfinite(period_s), period_s, 1.0)
    walk = start[:, None] + fit.travel[:, None] * 2 * np.pi * (np.arange(length) * ts_s)[None, :] / period[:, None]
    out = fit.curve(walk)[..., 0]
    out[~np.isfinite(period_s)] = np.nan
    return out


def cycle_features(fit: InlpcaFit, period_s: np.ndarray) -> np.ndarray:
    """[W, CYCLE_FEATURES]: curve OP and PV (mean removed from PV), time shares, period."""
    n_win = fit.travel.size
    start = _angle_of_max_op(fit)
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
