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

from detect.oscillation import HYSTERESIS_STD, _crossings, detrend

STICTION = 0.6
NO_STICTION = 0.4
APEXES = 9
"""Apex positions tried per half cycle (shares of it from 0.1 to 0.9)."""


def _fit_error(seg: np.ndarray, shape: np.ndarray) -> float:
    """Mean square error of ``seg`` against ``a * shape + b`` at the best a, b."""
    design = np.stack([shape, np.ones_like(shape)], axis=1)
    coef, *_ = np.linalg.lstsq(design, seg, rcond=None)
    r = seg - design @ coef
    return float(np.mean(r * r))


def stiction_index(x: np.ndarray) -> float:
    """SI of one signal, nan where it has fewer than two whole half cycles."""
    y = detrend(np.asarray(x, float))
    sd = float(np.std(y))
    if not sd > 0:
        return float("nan")
    width = max(1, min(y.size // 50, 5))
    smooth = np.convolve(y, np.ones(width) / width, mode="same") if width > 1 else y
    zc = _crossings(smooth, HYSTERESIS_STD * sd)
    if zc.size < 3:
        return float("nan")
    mse_sine = mse_triangle = 0.0
    for a, b in zip(zc[:-1], zc[1:], strict=True):
        seg = y[a : b + 1]
        if seg.size < 5:
            continue
        u = np.linspace(0.0, 1.0, seg.size)
        mse_sine += _fit_error(seg, np.sin(np.pi * u))
        best = np.inf
        for apex in np.linspace(0.1, 0.9, APEXES):
            triangle = np.where(u <= apex, u / apex, (1 - u) / (1 - apex))
            best = min(best, _fit_error(seg, triangle))
        mse_triangle += best
    total = mse_sine + mse_triangle
    return float(mse_sine / total) if total > 0 else float("nan")
