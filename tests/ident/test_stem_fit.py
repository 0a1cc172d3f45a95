"""A measured stem against OP (``ident.stem_fit``, ``ident.valve_check``): Choudhury's two-parameter valve is read
where the stem has one, the physical valve where it has that, and a stem that follows OP is linear."""

import numpy as np
import pytest

from stiction.ident import stem_fit
from stiction.ident.valve_check import MIN_BAND_PCT, check_valve


def _two_parameter_stem(op: np.ndarray, s: float, j: float) -> np.ndarray:
    """Choudhury's valve written out one sample at a time, apart from ``sim.two_parameter``'s vectorised step: it
    sticks where its input stops or turns, and moves again once the input has left that point by more than S (turned)
    or J (the same way), then follows the input less (S - J) / 2."""
    out, stuck, x_stick, dir_stick, v_prev, y = np.empty(op.size), True, op[0], 0.0, 0.0, op[0]
    out[0] = y
    for k in range(1, op.size):
        v = float(np.sign(op[k] - op[k - 1]))
        if not stuck and (v == 0 or (v_prev != 0 and v != v_prev)):
            stuck, x_stick, dir_stick = True, op[k - 1], v_prev
        if stuck and v != 0 and abs(op[k] - x_stick) > (j if v == dir_stick else s):
            stuck = False
        if not stuck:
            y = op[k] - v * (s - j) / 2
        v_prev = v if v != 0 else v_prev
        out[k] = y
    return out


def _op(n: int, seed: int) -> np.ndarray:
    """A controller's output: a slow cycle of 40 % with a wander on it and the jitter its proportional action puts
    on PV's noise, so that it turns every few samples."""
    rng = np.random.default_rng(seed)
    t = np.arange(n, dtype=float)
    return 50 + 20 * np.sin(2 * np.pi * t / 150) + np.cumsum(rng.normal(0.0, 0.3, n)) + rng.normal(0.0, 0.1, n)


def test_the_lanes_sums_give_each_valves_calibrated_fit_as_one_path_and_a_least_squares_do():
    """``scores`` runs every lane at once and keeps only the regression's sums: each lane's (rss, offset, gain) is
    what its kept path (``path``) and a plain least squares give."""
    op = _op(400, 1)
    stem = 0.9 * _two_parameter_stem(op, 3.0, 1.0) + 2.0 + 0.1 * np.random.default_rng(2).standard_normal(op.size)
    drives = stem_fit.lagged(op, np.array([0.0, 2.0]), 1.0)
    lanes, s, j, first = np.array([0, 1, 0, 1]), np.array([0.0, 3.0, 3.0, 1.5]), np.array([0.0, 1.0, 3.0, 0.0]), 20
    rss, offset, gain = stem_fit.scores(drives, lanes, stem, s, j, first)
    for k in range(lanes.size):
        y = stem_fit.path(drives[lanes[k]], s[k], j[k])
        x = np.stack([np.ones(op.size - 1 - first), y[first:-1]], axis=1)  # interval k's stem is sample k + 1's
        coef, *_ = np.linalg.lstsq(x, stem[first + 1 :], rcond=None)
        resid = stem[first + 1 :] - x @ coef
        assert offset[k] == pytest.approx(coef[0], rel=1e-9, abs=1e-9)
        assert gain[k] == pytest.approx(coef[1], rel=1e-9, abs=1e-12)
        assert rss[k] == pytest.approx(resid @ resid, rel=1e-7, abs=1e-9)


@pytest.mark.parametrize("s_pct, j_pct", [(5.0, 5.0), (5.0, 2.0), (4.0, 0.0), (1.0, 0.5)])
def test_a_stem_that_sticks_where_op_turns_and_then_follows_it_is_read_sticky_with_its_band(s_pct, j_pct):
    """The two-parameter valve behind a lag of a sample, its stem stored with an offset, a gain of 0.95 and noise of
    0.1 %.  The physical valve alone read such stems linear (S 5, J 5 by 10 of the criterion)."""
    op = _op(1200, 3)
    drive = stem_fit.lagged(op, np.array([1.0]), 1.0)[0]
    noise = 0.1 * np.random.default_rng(4).standard_normal(op.size)
    valve = _two_parameter_stem(drive, s_pct, j_pct)
    stem = 2.0 + 0.95 * np.concatenate([valve[:1], valve[:-1]]) + noise  # the drive over an interval, the stem after it
    v = check_valve(op, stem, 1.0)
    assert v.sticky and v.delta_criterion > 0
    assert abs(v.s_pct - s_pct) <= 2 * v.s_se_pct and v.s_se_pct <= 0.3 * s_pct
    assert abs(v.j_pct - j_pct) <= 2 * v.j_se_pct
    assert v.calibration_gain == pytest.approx(0.95, abs=0.03)


@pytest.mark.parametrize("lag_s, noise_pct", [(0.0, 0.05), (2.0, 0.1), (3.0, 0.3)])
def test_a_stem_that_follows_op_is_linear(lag_s, noise_pct):
    op = _op(1200, 5)
    stem = 1.0 + 1.02 * stem_fit.lagged(op, np.array([lag_s]), 1.0)[0]
    stem = stem + noise_pct * np.random.default_rng(6).standard_normal(op.size)
    v = check_valve(op, stem, 1.0)
    assert not v.sticky
    assert v.calibration_gain == pytest.approx(1.02, abs=0.02)


def test_a_band_under_a_good_valves_resolution_is_no_sticky_valve():
    op = _op(1200, 7)
    stem = _two_parameter_stem(op, 0.5 * MIN_BAND_PCT, 0.0) + 0.01 * np.random.default_rng(8).standard_normal(op.size)
    assert not check_valve(op, stem, 1.0).sticky


def test_a_recorded_stem_that_cannot_be_read_says_why_in_one_line_and_none_is_read():
    from stiction.quantify.stem import stem_check

    op = _op(600, 9)
    assert stem_check(op, None, 1.0) == (None, None)  # no stem recorded: nothing to say
    for mv, why in ((np.full(op.size, 42.0), "does not move"), (op.copy(), "repeats OP"),
                    (op[:-5], "OP has 600")):  # fmt: skip
        check, note = stem_check(op, mv, 1.0)
        assert check is None and why in note and "\n" not in note
