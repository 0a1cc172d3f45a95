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

from detect.oscillation import detrend, half_cycles

STICTION = 0.6
NO_STICTION = 0.4
APEXES = 9
"""Apex positions tried per half cycle (shares of it from 0.1 to 0.9)."""


def _fit_errors(seg: np.ndarray, shapes: np.ndarray) -> np.ndarray:
    """[S] mean square error of ``seg`` against ``a * shape + b`` at the best a, b, for each row of
    ``shapes`` [S, m]: least squares in closed form on the centred signals."""
    y = seg - seg.mean()
    s = shapes - shapes.mean(axis=1, keepdims=True)
    sse = y @ y - (s @ y) ** 2 / np.einsum("ij,ij->i", s, s)
    return np.maximum(sse, 0.0) / seg.size


def stiction_index(x: np.ndarray) -> float:
    """SI of one signal, nan where it has fewer than two whole half cycles."""
    y = detrend(np.asarray(x, float))
    sd = float(np.std(y))
    if not sd > 0:
        return float("nan")
    _, zc = half_cycles(y, sd)
    if zc.size < 3:
        return float("nan")
    apexes = np.linspace(0.1, 0.9, APEXES)[:, None]
    mse_sine = mse_triangle = 0.0
    for a, b in zip(zc[:-1], zc[1:], strict=True):
        seg = y[a : b + 1]
        if seg.size < 5:
            continue
        u = np.linspace(0.0, 1.0, seg.size)
        triangles = np.where(u <= apexes, u / apexes, (1 - u) / (1 - apexes))
        errors = _fit_errors(seg, np.vstack([np.sin(np.pi * u), triangles]))
        mse_sine += errors[0]
        mse_triangle += errors[1:].min()
    total = mse_sine + mse_triangle
    return float(mse_sine / total) if total > 0 else float("nan")
