"""Oscillation period from the autocorrelation function (thesis 4.5), batched over windows."""

from __future__ import annotations

import numpy as np

from stiction.detect.oscillation import autocorrelation

__all__ = ["acf_period", "autocorrelation"]


def acf_period(x: np.ndarray, ts_s: float = 1.0, min_lag: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Period [s] and regularity of each row: the first ACF peak after its first zero crossing.

    The peak's lag is refined by a parabola through its neighbours; its height (1 for a
    perfectly periodic signal, near 0 for noise) is returned as the regularity.  Rows
    without such a peak get ``nan``.
    """
    x = np.atleast_2d(np.asarray(x, dtype=float))
    n = x.shape[1]
    r = autocorrelation(x, n // 2)
    periods = np.full(x.shape[0], np.nan)
    heights = np.full(x.shape[0], np.nan)
    for i, ri in enumerate(r):
        below = np.flatnonzero(ri[min_lag:] < 0)
        if below.size == 0:
            continue
        start = min_lag + below[0]
        seg = ri[start:]
        peaks = np.flatnonzero((seg[1:-1] > seg[:-2]) & (seg[1:-1] >= seg[2:]) & (seg[1:-1] > 0)) + 1
        if peaks.size == 0:
            continue
        k = start + peaks[np.argmax(seg[peaks] > 0.5 * seg[peaks].max())]
        a, b, c = ri[k - 1], ri[k], ri[k + 1]
        denom = a - 2 * b + c
        shift = 0.5 * (a - c) / denom if denom < 0 else 0.0
        periods[i] = (k + shift) * ts_s
        heights[i] = b
    return periods, heights
