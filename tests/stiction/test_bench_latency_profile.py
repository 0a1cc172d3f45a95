"""The throughput bench's latency over the run: which 10 s of stream the late reports came from."""

import numpy as np
import pytest

from stiction.bench.throughput import _p99_by_bucket


def test_p99_per_bucket_of_stream_with_empty_buckets_shown_as_none():
    rng = np.random.default_rng(0)
    early = [(int(k), float(x)) for k, x in zip(rng.integers(0, 10, 200), rng.uniform(0, 1, 200), strict=True)]
    late = [(25, 3.0), (29, 5.0)]
    profile = _p99_by_bucket(early + late, 10)
    assert len(profile) == 3 and profile[1] is None
    assert profile[0] == pytest.approx(np.percentile([x for _, x in early], 99))
    assert profile[2] == pytest.approx(np.percentile([3.0, 5.0], 99))
    assert _p99_by_bucket([], 10) == []
