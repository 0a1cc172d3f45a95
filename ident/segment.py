"""Optimal segmentation of a signal into constant pieces (penalised least squares).

A sticky stem is still between slips, so any signal proportional to its position is
piecewise constant plus noise; the pieces' ends are the slips.
"""

from __future__ import annotations

import numpy as np


def segment_ends(f: np.ndarray, penalty: np.ndarray) -> list[list[int]]:
    """Optimal partition of each row of ``f`` [W, N] into constant pieces: the pieces' end indices.

    Dynamic programming over the end of the last piece, ``F[t] = min_s F[s] + SSE(s, t) + penalty``
    (Jackson et al. 2005, "An algorithm for optimal partitioning of data on an interval"),
    vectorised over rows and start points: O(N^2) per row.
    """
    n_win, n = f.shape
    c1 = np.concatenate([np.zeros((n_win, 1)), np.cumsum(f, axis=1)], axis=1)
    c2 = np.concatenate([np.zeros((n_win, 1)), np.cumsum(f * f, axis=1)], axis=1)
    best = np.full((n_win, n + 1), np.inf)
    best[:, 0] = -penalty
    last = np.zeros((n_win, n + 1), dtype=int)
    rows = np.arange(n_win)
    for t in range(1, n + 1):
        length = t - np.arange(t)
        sse = (c2[:, t : t + 1] - c2[:, :t]) - (c1[:, t : t + 1] - c1[:, :t]) ** 2 / length
        total = best[:, :t] + sse + penalty[:, None]
        j = np.argmin(total, axis=1)
        best[:, t], last[:, t] = total[rows, j], j
    ends = []
    for w in range(n_win):
        e, t = [], n
        while t > 0:
            e.append(t)
            t = last[w, t]
        ends.append(e[::-1])
    return ends


def noise_variance(f: np.ndarray) -> np.ndarray:
    """Per row of ``f`` [W, N]: the white-noise variance read from the MAD of first differences."""
    d = np.diff(f, axis=1)
    return (1.4826 * np.median(np.abs(d - np.median(d, axis=1, keepdims=True)), axis=1)) ** 2 / 2
