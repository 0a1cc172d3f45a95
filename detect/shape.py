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

from stiction.detect import kernels
from stiction.detect.oscillation import Detrended, detrended, half_cycles

STICTION = 0.6
NO_STICTION = 0.4
APEXES = 9
"""Apex positions tried per half cycle (shares of it from 0.1 to 0.9)."""
APEX_SHARES = np.linspace(0.1, 0.9, APEXES)
MIN_HALF_SAMPLES = 5


def stiction_index(x: np.ndarray, d: Detrended | None = None) -> float:
    """SI of one signal, nan where it has fewer than two whole half cycles (``d``: its ``detrended``, where
    the caller has it).

    Every half cycle ``y[a..b]`` (both ends) of at least ``MIN_HALF_SAMPLES`` samples is fitted with
    ``p * shape + q`` for the half sine and each triangle, in closed form from per-half-cycle sums
    (``SSE = Syy - Sys^2 / Sss`` on centred sums), compiled in ``detect.kernels``."""
    d = d if d is not None else detrended(np.asarray(x, float))
    y, sd = d.y, d.sd
    if not sd > 0:
        return float("nan")
    _, zc = half_cycles(y, sd)
    if zc.size < 3:
        return float("nan")
    mse_sine, mse_triangle, used = kernels.shape_errors(np.ascontiguousarray(y), zc, APEX_SHARES, MIN_HALF_SAMPLES)
    total = mse_sine + mse_triangle
    return float(mse_sine / total) if used and total > 0 else float("nan")
