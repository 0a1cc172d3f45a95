"""A measured stem against OP through Choudhury's two-parameter valve: band S and slip J searched on a grid.

The physical valve of ``ident.fit`` (the thesis's spring and friction) slips in jumps while its drive ramps: a stem
held between slips.  Choudhury's data-driven valve (Choudhury, Thornhill & Shah 2005; ``sim.two_parameter``)
sticks where its input stops or turns, breaks away once the input has left that point by S (turned) or J (the same
way), and then follows the input: a backlash with a jump, as many measured valves move.  A stem measured so reads as
a linear valve to the physical model alone (a stem of S 5 %, J 5 % over OP sines of 40 %: linear by 10 of Schwarz's
criterion).  Here the valve is simulated for every (lag, S, J) of a grid at once, its path calibrated to the
measured stem by least squares (an offset and a gain: the positioner's calibration), and the best scored by
Schwarz's criterion on the stem's own residual; S = 0 is the linear valve.  The grid is refined once around the
best, and S's and J's standard errors are the half widths of the profile where the criterion, over the residual's
effective samples, stays within 1 of its least.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.ident.fit import criterion
from stiction.ident.friction import effective_samples
from stiction.ident.valve_model import drive_of
from stiction.sim.two_parameter import choudhury_step

LAGS_TS = (0.0, 0.3, 0.6, 1.0, 1.5, 2.0, 3.0, 5.0)
"""The actuator lags the sticky valve's coarse grid searches, in sample times (and ``ident.valve_check``'s physical
valve)."""
FINE_LAG_STEP_TS = 0.1
FINE_LAG_MAX_TS = 6.0
"""The linear valve's lags, and the sticky valve's about its best: a tenth of a sample apart, up to six samples."""
S_POINTS = 36
S_LOWEST_SHARE = 0.002
"""The bands searched: ``S_POINTS`` on a log grid from this share of OP's range to its whole range."""
J_SHARES = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
"""The slips searched, as shares of the band (J = 0: a backlash; J = S: a stick-slip that lands on the input)."""
WARMUP_SHARE = 0.05
"""The first samples are not scored: the valve's state when the record starts is not known."""
PARAMS_LINEAR = 3
PARAMS_STICKY = 5
"""Lag, offset and gain; with S and J."""


@dataclass(frozen=True)
class StemFit:
    """The best valve of each kind on the measured stem: its criterion, lag (s) and calibration (the stem about
    ``offset + gain x`` the model's path, RMS error in % of travel); the sticky one's S and J (% of OP) with errors."""

    sticky_criterion: float
    s_pct: float
    j_pct: float
    s_se_pct: float
    j_se_pct: float
    actuator_tau_s: float
    sticky_offset_pct: float
    sticky_gain: float
    sticky_error_pct: float
    linear_criterion: float
    linear_tau_s: float
    linear_offset_pct: float
    linear_gain: float
    linear_error_pct: float


def lagged(op: np.ndarray, lags_s: np.ndarray, ts_s: float) -> np.ndarray:
    """[L, N] OP through a first-order lag of each ``lags_s`` (0: OP itself): the drive's mean over each interval, as
    ``ident.valve_model.drive_of`` gives the physical valve's (a linear valve is the same path in both fits)."""
    return np.stack([drive_of(op, float(lag), ts_s).mean for lag in lags_s])


def scores(drives: np.ndarray, lane_drive: np.ndarray, stem: np.ndarray, s: np.ndarray, j: np.ndarray, first: int):
    """For each lane [L] (its drive, a row of ``drives`` [D, N], band ``s`` and slip ``j``): the valve's path through
    Choudhury's model over intervals ``first`` to N - 2, calibrated to ``stem`` one sample later by least squares, as
    (rss, offset, gain).  The paths are not kept: the regression's sums are gathered as they run."""
    lanes, n = lane_drive.size, drives.shape[1]
    columns = drives.T  # [N, D]: one sample of every drive, contiguous
    x_prev = columns[0][lane_drive]
    y, stuck, x_stick = x_prev.copy(), np.ones(lanes, bool), x_prev.copy()
    dir_stick, v_prev = np.zeros(lanes), np.zeros(lanes)
    sy = syy = sym = np.zeros(lanes)
    for k in range(1, n - 1):
        x = columns[k][lane_drive]
        y, stuck, x_stick, dir_stick, v_prev = choudhury_step(x, x_prev, y, stuck, x_stick, dir_stick, v_prev, s, j)
        x_prev = x
        if k >= first:  # the drive over interval k is the stem at sample k + 1 (as ``ident.friction.stem_path``)
            sy, syy, sym = sy + y, syy + y * y, sym + y * stem[k + 1]
    m = stem[first + 1 :]
    count, sm, smm = m.size, float(m.sum()), float(m @ m)
    var = count * syy - sy * sy
    gain = np.where(var > 1e-12 * count * count, (count * sym - sy * sm) / np.where(var > 0, var, 1.0), 0.0)
    offset = (sm - gain * sy) / count
    rss = smm - 2 * offset * sm - 2 * gain * sym + count * offset**2 + 2 * offset * gain * sy + gain**2 * syy
    return np.maximum(rss, 0.0), offset, gain


def path(drive: np.ndarray, s: float, j: float) -> np.ndarray:
    """[N] one valve's path (``scores``'s, kept)."""
    y, stuck, x_stick = drive[:1].copy(), np.ones(1, bool), drive[:1].copy()
    dir_stick, v_prev = np.zeros(1), np.zeros(1)
    out = np.empty(drive.size)
    out[0] = y[0]
    for k in range(1, drive.size):
        y, stuck, x_stick, dir_stick, v_prev = choudhury_step(
            drive[k : k + 1], drive[k - 1 : k], y, stuck, x_stick, dir_stick, v_prev, np.array([s]), np.array([j])
        )
        out[k] = y[0]
    return out


def _grid(lags: np.ndarray, bands: np.ndarray, shares: np.ndarray):
    lag, band, share = (a.ravel() for a in np.meshgrid(lags, bands, shares, indexing="ij"))
    return lag, band, band * share


def fit_stem(op_pct: np.ndarray, mv_pct: np.ndarray, ts_s: float) -> StemFit:
    """The two-parameter valve and the linear one fitted to the measured stem ``mv_pct`` from ``op_pct``."""
    op, stem = np.asarray(op_pct, float), np.asarray(mv_pct, float)
    n = op.size
    first = max(1, int(WARMUP_SHARE * n))
    scored = n - 1 - first
    # the drives: OP over each interval through each lag (a tenth of a sample apart), its stem a sample later (as
    # ``ident.friction``), half a sample later or at once (the record's stamps taken after the control step): how a
    # historian stamps the stem against OP is not known.  A lag off the grid would read as a band.
    fine = np.round(np.arange(0.0, FINE_LAG_MAX_TS + 1e-9, FINE_LAG_STEP_TS), 6)
    late = lagged(op, fine * ts_s, ts_s)
    early = np.concatenate([late[:, 1:], late[:, -1:]], axis=1)
    drives = np.vstack([late, 0.5 * (late + early), early])
    lags = np.tile(fine, 3)
    coarse = np.flatnonzero(np.isin(np.round(lags, 6), np.round(np.asarray(LAGS_TS, float), 6)))
    span = max(float(np.ptp(op)), 1e-9)
    bands = span * np.geomspace(S_LOWEST_SHARE, 1.0, S_POINTS)

    def run(lag_idx, s, j):
        return scores(drives, lag_idx, stem, s, j, first)

    # the linear valve: every lag and alignment, S = J = 0
    lin_rss, lin_off, lin_gain = run(np.arange(lags.size), np.zeros(lags.size), np.zeros(lags.size))
    lin = int(np.argmin(lin_rss))
    linear_ic = float(criterion(lin_rss[lin], PARAMS_LINEAR, scored))
    # the sticky valve: a coarse grid, then a finer one about its best
    lag_i, s, j = _grid(coarse, bands, np.asarray(J_SHARES))
    rss, _, _ = run(lag_i, s, j)
    best = int(np.argmin(rss))
    ratio = bands[1] / bands[0]
    fine_bands = s[best] * np.geomspace(1 / ratio, ratio, 9)
    share = j[best] / s[best]
    fine_shares = np.clip(share + np.linspace(-0.2, 0.2, 9), 0.0, 1.0)
    near = np.flatnonzero(np.abs(lags - lags[lag_i[best]]) <= 1.0 + 1e-9)  # every alignment, within a sample's lag
    lag_i, s, j = _grid(near, fine_bands, np.unique(fine_shares))
    rss, offset, gain = run(lag_i, s, j)
    best = int(np.argmin(rss))
    sticky_ic = float(criterion(rss[best], PARAMS_STICKY, scored))
    # the profile over bands, slips, lags and alignments: S's and J's spread where the criterion over the effective
    # samples stays within 1 of its least
    resid = stem[first + 1 :] - offset[best] - gain[best] * path(drives[lag_i[best]], s[best], j[best])[first:-1]
    n_eff = effective_samples(resid)
    inside = n_eff * np.log(np.maximum(rss, 1e-300) / max(rss[best], 1e-300)) <= 1.0
    step_s = s[best] * (ratio ** (1 / 4) - 1)  # the fine grid's spacing: no error below it
    s_se = max(float(np.ptp(s[inside])) / 2, step_s / 2)
    j_se = max(float(np.ptp(j[inside])) / 2, step_s / 2)
    return StemFit(
        sticky_criterion=sticky_ic,
        s_pct=float(s[best]),
        j_pct=float(j[best]),
        s_se_pct=s_se,
        j_se_pct=j_se,
        actuator_tau_s=float(lags[lag_i[best]]) * ts_s,
        sticky_offset_pct=float(offset[best]),
        sticky_gain=float(gain[best]),
        sticky_error_pct=float(np.sqrt(rss[best] / scored)),
        linear_criterion=linear_ic,
        linear_tau_s=float(lags[lin]) * ts_s,
        linear_offset_pct=float(lin_off[lin]),
        linear_gain=float(lin_gain[lin]),
        linear_error_pct=float(np.sqrt(lin_rss[lin] / scored)),
    )
