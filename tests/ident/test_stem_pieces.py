"""The stem's pieces from a segmentation (compiled in ``ident.kernels.path_pieces``) against the
plain-Python reading they replaced, and the load separation's piecewise means against a loop."""

from __future__ import annotations

import numpy as np
import pytest

from stiction.ident import stem
from stiction.ident.stem import MIN_JUMP_SD


def _pieces_by_loop(u, ends, noise_sd):
    """(starts, levels) as ``ident.stem._path`` read them before they were compiled."""
    bounds = [0, *ends]
    drop = set()
    for i in range(1, len(bounds) - 2):
        a, b = bounds[i], bounds[i + 1]
        if b - a == 1 and min(u[a - 1], u[b]) < u[a] < max(u[a - 1], u[b]):
            drop.add(b if abs(u[a] - u[b]) < abs(u[a] - u[a - 1]) else a)
    bounds = [x for x in bounds if x not in drop]
    total = np.concatenate([[0.0], np.cumsum(u)]).tolist()

    def mean(a, b):
        return (total[b] - total[a]) / (b - a)

    starts, levels = [bounds[0]], [mean(0, bounds[1])]
    for a, b in zip(bounds[1:-1], bounds[2:], strict=True):
        level = mean(a, b)
        se = noise_sd * np.sqrt(1.0 / (b - a) + 1.0 / (a - starts[-1]))
        if abs(level - levels[-1]) < MIN_JUMP_SD * se:
            levels[-1] = mean(starts[-1], b)
            continue
        starts.append(a)
        levels.append(level)
    return np.array(starts), np.array(levels)


@pytest.mark.parametrize("seed", range(4))
def test_compiled_pieces_are_the_plain_reading(seed):
    rng = np.random.default_rng(seed)
    for _ in range(200):
        n = int(rng.integers(3, 300))
        # steps of 1-3 samples (pieces of one sample between two levels among them) under noise
        u = np.repeat(rng.normal(size=n) * rng.uniform(0, 3), rng.integers(1, 4, size=n))
        u = u + rng.normal(0, 0.1, u.size)
        cut = rng.choice(np.arange(1, u.size), size=int(rng.integers(1, min(60, u.size - 1) + 1)), replace=False)
        ends = sorted(cut.tolist()) + [u.size]
        sd = float(rng.uniform(0.01, 0.5))
        k0 = int(rng.integers(-3, 3))
        starts, levels = _pieces_by_loop(u, ends, sd)
        got = stem._path(u, k0, ends, sd, u.size + k0)
        slips = starts[1:] + k0
        keep = (slips >= 1) & (slips < u.size + k0)
        first = int(np.argmax(keep)) if keep.any() else slips.size
        want = np.concatenate([levels[first : first + 1], levels[1:][keep]]) if keep.any() else levels[:1]
        assert np.array_equal(got.slips, slips[keep])
        assert np.array_equal(got.levels, want)
        assert np.array_equal(got.directions, np.sign(np.diff(want)).astype(int))


def test_piecewise_means_are_each_piece_s_mean():
    rng = np.random.default_rng(5)
    u = np.repeat(rng.normal(0, 2, 40), rng.integers(1, 30, 40)) + rng.normal(0, 0.05, size=None)
    u = u + rng.normal(0, 0.05, u.size)
    got = stem._pieces(u, 0.05)
    # every run of equal values is one piece, and holds the mean of u over it
    change = np.flatnonzero(np.diff(got) != 0) + 1
    for a, b in zip(np.r_[0, change], np.r_[change, u.size], strict=True):
        assert np.allclose(got[a:b], u[a:b].mean(), rtol=0, atol=1e-12)
    assert change.size >= 20  # the steps of 2 against noise of 0.05 are found
