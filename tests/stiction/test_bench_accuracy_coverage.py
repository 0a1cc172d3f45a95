"""``stiction bench accuracy`` judges the reported uncertainty: the share of truths within two standard errors."""

import numpy as np

from stiction.bench.accuracy import EXACT_PP, _within_2se


def test_the_share_inside_two_errors_counts_each_number_given_and_an_exact_reading_as_inside():
    truth = np.array([[10.0, 5.0], [20.0, 8.0], [30.0, 9.0], [40.0, 1.0]])
    est = np.array([[10.5, 5.0 + EXACT_PP / 2], [23.0, 8.1], [np.nan, np.nan], [40.1, 3.0]])
    se = np.array([[0.3, 0.0], [1.0, 0.1], [np.nan, np.nan], [0.1, 0.5]])
    # fs: 0.5 <= 0.6 inside, 3 > 2 outside, not given, 0.1 <= 0.2 inside; fd: exact inside, 0.1 <= 0.2, -, 2 > 1
    assert _within_2se(est, se, truth) == [2 / 3, 2 / 3]
    assert _within_2se(np.full((2, 2), np.nan), np.full((2, 2), np.nan), truth[:2]) == [None, None]
