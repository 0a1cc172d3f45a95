"""Records stored in steps: the lattice a historian's quantisation leaves in the values."""

from __future__ import annotations

import numpy as np

MIN_STEPS = 3
"""A lattice must be coarse enough to show: the signal spans at least this many steps... and few enough values."""


def _few_values(x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """The finite samples and their distinct values, or None for the values where there are
    too few to show steps or too many (more than half the samples) to be stored in steps."""
    x = np.asarray(x, float)
    x = x[np.isfinite(x)]
    values = np.unique(x)
    if values.size < MIN_STEPS or values.size > 0.5 * x.size:
        return x, None
    return x, values


def quantum(x: np.ndarray, tolerance: float = 0.02) -> float | None:
    """The step of the lattice every value of ``x`` sits on, or None (values on no common grid).

    The candidate step is the smallest gap between distinct values; the record is quantised
    when (almost) every value is a whole number of such steps from the lowest value, and the
    signal takes far fewer distinct values than it has samples.
    """
    x, values = _few_values(x)
    if values is None:
        return None
    gaps = np.diff(values)
    scale = max(float(np.max(np.abs(values))), 1e-12)
    gaps = gaps[gaps > 1e-9 * scale]
    if gaps.size == 0:
        return None
    # candidates: the smallest distinct gaps (an export's decimal rounding makes equal gaps differ
    # in their last digits, so gaps within 2 % of each other count as one)
    cands = []
    for g in np.sort(gaps):
        if not cands or g > 1.02 * cands[-1]:
            cands.append(float(g))
        if len(cands) == 5:
            break
    span = float(np.ptp(values))
    for cand in cands:
        # the step, refined over every gap's whole number of steps
        steps = np.maximum(np.round(gaps / cand), 1.0)
        cand = float(np.sum(steps * gaps) / np.sum(steps * steps))
        k = (values - values[0]) / cand
        on_grid = np.mean(np.abs(k - np.round(k)) < max(tolerance, 0.05)) > 0.99
        # a lattice is used densely: a step far finer than the values' spacing is the export's rounding
        dense = values.size >= 0.2 * (span / cand + 1)
        if on_grid and dense:
            q = cand
            break
    else:
        return None
    return q if np.ptp(x) >= MIN_STEPS * q else None


def snap(x: np.ndarray, q: float, origin: float) -> np.ndarray:
    """``x`` rounded onto the lattice ``origin + k q``."""
    return origin + np.round((np.asarray(x) - origin) / q) * q


def resolution(x: np.ndarray) -> float | None:
    """The typical step between a record's distinct values, where it has few of them (None otherwise).

    Wider than ``quantum``: values stored in steps that vary along the range (a flow computed
    from a quantised differential pressure, say) have a resolution but no single lattice.
    """
    _, values = _few_values(x)
    if values is None:
        return None
    gaps = np.diff(values)
    gaps = gaps[gaps > 1e-3 * np.ptp(values)]  # near-duplicates: the export's decimal rounding
    return float(np.median(gaps)) if gaps.size else None
