"""The segmentation against an exhaustive search of every partition."""

from itertools import combinations

import numpy as np
import pytest

from stiction.ident.segment import noise_variance, segment_ends


def _exhaustive(f, penalty):
    """Every partition of a short series: the least penalised squared error."""
    n, best = f.size, (np.inf, None)
    for k in range(n):
        for cuts in combinations(range(1, n), k):
            bounds = [0, *cuts, n]
            cost = sum(np.sum((f[a:b] - f[a:b].mean()) ** 2) for a, b in zip(bounds[:-1], bounds[1:], strict=True))
            cost += penalty * (len(bounds) - 1)
            if cost < best[0]:
                best = (cost, bounds[1:])
    return best[1]


@pytest.mark.parametrize("seed", range(6))
def test_segmentation_is_the_optimal_partition(seed):
    rng = np.random.default_rng(seed)
    f = np.repeat(rng.normal(0, 3, 4), 3)[:11] + rng.normal(0, 0.5, 11)
    penalty = float(rng.uniform(0.2, 3))
    assert segment_ends(f[None, :], np.array([penalty]))[0] == _exhaustive(f, penalty)


def test_noise_variance_reads_white_noise_through_steps():
    rng = np.random.default_rng(3)
    f = np.repeat([0.0, 5.0, -2.0, 4.0], 500) + rng.normal(0, 0.3, 2000)
    assert noise_variance(f[None, :])[0] == pytest.approx(0.09, rel=0.1)


def test_long_series_partition_is_no_worse_than_the_truth():
    """On a long series the optimal partition costs at most what the true pieces cost."""
    rng = np.random.default_rng(7)
    bounds = np.sort(rng.choice(np.arange(10, 990), 20, replace=False))
    f = np.repeat(rng.normal(0, 4, 21), np.diff(np.concatenate([[0], bounds, [1000]]))) + rng.normal(0, 1, 1000)
    penalty = 2 * np.log(1000)

    def cost(ends):
        starts = [0, *ends[:-1]]
        sse = sum(np.sum((f[a:b] - f[a:b].mean()) ** 2) for a, b in zip(starts, ends, strict=True))
        return sse + penalty * len(ends)

    found = segment_ends(f[None, :], np.array([penalty]))[0]
    assert cost(found) <= cost([*bounds.tolist(), 1000]) + 1e-9
