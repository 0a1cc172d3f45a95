"""The shape test of He, Wang, Pottmann & Qin (2007), "A curve fitting method for detecting
valve stiction in oscillating control loops", Ind. Eng. Chem. Res. 46.

Under stiction the controller output of a self-regulating loop (and the PV of an integrating
one) is triangular; a load or tuning oscillation is sinusoidal.  Each half cycle between
zero crossings is fitted with a half sine and with a triangle of free apex; the stiction
index ``SI = MSE_sine / (MSE_sine + MSE_triangle)`` is above 0.6 for stiction, below 0.4
for none.
"""

from __future__ import annotations

import numpy as np

from detect.oscillation import detrend, half_cycles, run_positions

STICTION = 0.6
NO_STICTION = 0.4
APEXES = 9
"""Apex positions tried per half cycle (shares of it from 0.1 to 0.9)."""


def stiction_index(x: np.ndarray) -> float:
    """SI of one signal, nan where it has fewer than two whole half cycles.

    Every half cycle ``y[a..b]`` (both ends) of at least 5 samples is fitted with ``p * shape + q``
    for the half sine and each triangle, in closed form from per-half-cycle sums, all half cycles
    at once: ``SSE = Syy - Sys^2 / Sss`` on centred sums."""
    y = detrend(np.asarray(x, float))
    sd = float(np.std(y))
    if not sd > 0:
        return float("nan")
    _, zc = half_cycles(y, sd)
    if zc.size < 3:
        return float("nan")
    a, b = zc[:-1], zc[1:]
    m = b - a + 1
    keep = m >= 5
    a, m = a[keep], m[keep]
    if a.size == 0:
        return float("nan")
    _, k = run_positions(m)  # each sample's position within its half cycle
    u = k / np.repeat(m - 1, m)
    yv = y[np.repeat(a, m) + k]
    apexes = np.linspace(0.1, 0.9, APEXES)[:, None]
    shapes = np.vstack([np.sin(np.pi * u), np.where(u <= apexes, u / apexes, (1 - u) / (1 - apexes))])  # [S, L]

    starts = np.cumsum(m) - m  # the half cycles are contiguous runs of the flat arrays

    def per_half(w):
        return np.add.reduceat(w, starts, axis=-1)

    sy, syy = per_half(yv), per_half(yv * yv)
    ss, sss, ssy = per_half(shapes), per_half(shapes * shapes), per_half(shapes * yv)
    cyy = syy - sy * sy / m
    css = sss - ss * ss / m
    csy = ssy - ss * sy / m
    mse = np.maximum(cyy - csy * csy / css, 0.0) / m  # [S, halves]
    mse_sine, mse_triangle = float(mse[0].sum()), float(mse[1:].min(axis=0).sum())
    total = mse_sine + mse_triangle
    return float(mse_sine / total) if total > 0 else float("nan")
