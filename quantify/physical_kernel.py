"""The physical reading's two sample-by-sample loops, compiled: the stem's recursion from the flow,
and the mean flow of each piece of a segmentation.

Run in numpy they were a Python loop over a window's samples (the recursion, vectorised over the
windows of a batch: 0.7 ms a window in the agent's batches of a few) and one ``np.mean`` call a piece
(hundreds a window: 1.2 ms).  ``quantify.physical`` keeps their definitions in its docstrings;
tests/quantify/test_physical.py holds these to plain numpy transcriptions.
Every kernel here divides without checking for a zero divisor (``error_model="numpy"``: inf or nan, as numpy
gives; the check was a branch at every division).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, error_model="numpy")
def stem_from_flow(flow, c):
    """MV [W, N+1] from the mean flow of each interval [W, N]: ``mv[k+1] = (flow[k] - c mv[k]) / (1 - c)``,
    ``mv[0] = flow[0]``."""
    n_win, n = flow.shape
    mv = np.empty((n_win, n + 1))
    for w in range(n_win):
        mv[w, 0] = flow[w, 0]
        for k in range(n):
            mv[w, k + 1] = (flow[w, k] - c * mv[w, k]) / (1 - c)
    return mv


@njit(cache=True, nogil=True, error_model="numpy")
def piece_means(f, ends):
    """Mean of ``f`` [N] over each piece ``[ends[i-1], ends[i])`` (the first from 0)."""
    out = np.empty(ends.size)
    start = 0
    for i in range(ends.size):
        total = 0.0
        for k in range(start, ends[i]):
            total += f[k]
        out[i] = total / (ends[i] - start)
        start = ends[i]
    return out
