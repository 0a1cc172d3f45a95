"""Records stored in steps: the lattice a historian's quantisation leaves in the values."""

from __future__ import annotations

import numpy as np

MIN_STEPS = 3
"""A lattice must be coarse enough to show: the signal spans at least this many steps... and few enough values."""


def quantum(x: np.ndarray, tolerance: float = 0.02) -> float | None:
    """The step of the lattice every value of ``x`` sits on, or None (values on no common grid).

    The candidate step is the smallest gap between distinct values; the record is quantised
    when (almost) every value is a whole number of such steps from the lowest value, and the
    signal takes far fewer distinct values than it has samples.
    """
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    values = np.unique(x)
    if values.size < MIN_STEPS or values.size > 0.5 * x.size:
        return None
    gaps = np.diff(values)
    scale = max(float(np.max(np.abs(values))), 1e-12)
    gaps = gaps[gaps > 1e-9 * scale]
    if gaps.size == 0:
        return None
    q = float(np.min(gaps))
    # robust to one odd gap: the smallest gap that most gaps are whole multiples of
    for cand in np.unique(np.round(np.sort(gaps)[: min(gaps.size, 5)], 12)):
        k = (values - values[0]) / cand
        if np.mean(np.abs(k - np.round(k)) < tolerance) > 0.99:
            q = float(cand)
            break
    else:
        return None
    return q if np.ptp(x) >= MIN_STEPS * q else None


def snap(x: np.ndarray, q: float, origin: float) -> np.ndarray:
    """``x`` rounded onto the lattice ``origin + k q``."""
    return origin + np.round((np.asarray(x) - origin) / q) * q
