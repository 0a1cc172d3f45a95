"""Optimal segmentation of a signal into constant pieces (penalised least squares).

A sticky stem is still between slips, so any signal proportional to its position is
piecewise constant plus noise; the pieces' ends are the slips.
"""

from __future__ import annotations

import numpy as np

from stiction.ident import kernels


def segment_ends(f: np.ndarray, penalty: np.ndarray) -> list[list[int]]:
    """Optimal partition of each row of ``f`` [W, N] into constant pieces: the pieces' end indices.

    Minimises ``SSE + penalty * pieces`` exactly (Jackson et al. 2005, "An algorithm for optimal
    partitioning of data on an interval", with the pruning of Killick et al. 2012); compiled in
    ``ident.kernels``.
    """
    f = np.atleast_2d(np.asarray(f, float))
    pen = np.broadcast_to(np.asarray(penalty, float), f.shape[:1])
    return [kernels.segment_row(np.ascontiguousarray(row), float(p)).tolist() for row, p in zip(f, pen, strict=True)]


def noise_variance(f: np.ndarray) -> np.ndarray:
    """Per row of ``f`` [W, N]: the white-noise variance read from the MAD of first differences."""
    d = np.diff(f, axis=1)
    return (1.4826 * np.median(np.abs(d - np.median(d, axis=1, keepdims=True)), axis=1)) ** 2 / 2
