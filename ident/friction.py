"""The valve read from a fit (``ident.fit``): band S and jump J in % of span, the thesis's fs and
fd, their standard errors (the residual's autocorrelation and, where the process gain is free,
the ridge it opens counted), and the stem path and PV the fitted model simulates."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.ident.objective import nuisance_basis, project_out
from stiction.ident.record import Record
from stiction.ident.valve_model import ValveFit, drive_of, path_regressors
from stiction.sim.valve import (
    PCT_OF_500LBF_PER_PCT_OF_SPAN,
    VALVE,
    band_and_jump_pct,
    lbf_to_pct,
    pct_to_lbf,
    stop_residual_in,
)


@dataclass(frozen=True)
class Friction:
    """The valve read from a fit: band and jump in % of span, and the thesis's fs/fd, with standard errors."""

    s_pct: float
    j_pct: float
    s_se_pct: float
    j_se_pct: float
    fs_pct: float
    fd_pct: float
    fs_se_pct: float
    fd_se_pct: float
    slips_read: int


def effective_samples(resid: np.ndarray) -> float:
    """Independent samples in an autocorrelated residual: n over its integrated autocorrelation time."""
    r = resid - resid.mean()
    c0 = float(r @ r)
    if c0 <= 0:
        return float(r.size)
    tau = 1.0
    for lag in range(1, min(200, r.size // 4)):
        rho = float(r[lag:] @ r[:-lag]) / c0
        if rho <= 0:
            break
        tau += 2 * rho
    return r.size / tau


PROFILE_POINTS = 41


def jump_profile_se(vf: ValveFit, record: Record, band: float) -> float:
    """J's uncertainty along the ridge a free process gain opens: the profile of the criterion over stop.

    With the gain free, a larger gain and a smaller jump explain the same PV (one slip per half
    cycle moves PV by K J): the least squares' covariance, conditional on the slips, misses how
    flat the criterion is along that ridge.  Here stop (so J = S - stop) is fixed on a grid from
    0 to S, the gain refitted, and J's interval read where the criterion (over the residual's
    effective samples) stays within 1 of its least.
    """
    hyp = vf.hypothesis
    if not hyp.gain_free or not np.isfinite(band) or band <= 0 or vf.slips.at.size == 0:
        return 0.0
    tf = vf.tf
    q = nuisance_basis(record, tf, 2 * np.pi / hyp.osc_period_s if hyp.osc_period_s else None)
    x = project_out(record.compared_response(tf, path_regressors(vf.slips, record.n, record.ts_s, hyp.snapshot)), q)
    y = project_out(record.target[None, :], q)[0]
    stops = np.linspace(0.0, band, PROFILE_POINTS)
    rss = np.empty(stops.size)
    for i, stop in enumerate(stops):
        cols = np.stack([x[0] + stop * x[1], x[3]] + ([x[2]] if hyp.actuator_tau_s > 0 else []))
        coef, *_ = np.linalg.lstsq(cols.T, y, rcond=None)
        resid = y - coef @ cols
        rss[i] = resid @ resid
    best = int(np.argmin(rss))
    n_eff = effective_samples(
        y
        - (
            np.linalg.lstsq(np.stack([x[0] + stops[best] * x[1], x[3]]).T, y, rcond=None)[0]
            @ np.stack([x[0] + stops[best] * x[1], x[3]])
        )
    )
    inside = stops[n_eff * np.log(rss / rss[best]) <= 1.0]
    return float(np.ptp(inside) / 2) if inside.size > 1 else 0.0


def friction(vf: ValveFit, record: Record) -> Friction:
    """The valve a fit read, in both conventions (``sim.valve.band_and_jump_pct``).

    The fit reads the static band ``b = fs / 12`` (searched, or from the brackets: how far the drive
    gets from the stem before it breaks away) and either the jump or the stop ``fd / 12`` (one from
    the least squares, the other the difference).  Choudhury's S, the OP travel after a reversal
    before the stem moves, is ``b + stop``; J is ``b - stop``.  Standard errors follow the fit's own
    parameters: where J is read, ``S = 2 b - J``; where stop is read, S and J share its error and b's.
    """
    b, b_se = vf.band_pct, vf.band_se
    # slips at a moving drive read J, the band comes from when they happen: stop is the difference;
    # slips at a held drive read stop, and J is the difference
    if np.isfinite(vf.jump_pct):
        j, j_se = vf.jump_pct, vf.jump_se
        stop, stop_se = b - j, float(np.hypot(b_se, j_se))
        s_se = float(np.hypot(2 * b_se, j_se))
    else:
        stop = vf.stop_pct
        # a free gain trades off against the jump: the profile's width, where wider than the covariance's
        stop_se = max(vf.stop_se, jump_profile_se(vf, record, b)) if np.isfinite(stop) else vf.stop_se
        j, j_se = b - stop, float(np.hypot(b_se, stop_se))
        s_se = j_se
    if not (np.isfinite(b) and np.isfinite(stop)):
        nan = float("nan")
        return Friction(nan, nan, nan, nan, nan, nan, nan, nan, int(vf.slips.read.sum()))
    fs, stop_pct_of_500lbf = b * PCT_OF_500LBF_PER_PCT_OF_SPAN, stop * PCT_OF_500LBF_PER_PCT_OF_SPAN
    s, j = band_and_jump_pct(fs, stop_pct_of_500lbf)
    stop_lbf = pct_to_lbf(stop_pct_of_500lbf)
    fd_lbf = stop_lbf - VALVE.spring_lbf_per_in * stop_residual_in(pct_to_lbf(fs) - stop_lbf)
    return Friction(
        float(s),
        float(j),
        s_se,
        j_se,
        float(fs),
        float(lbf_to_pct(fd_lbf)),
        b_se * PCT_OF_500LBF_PER_PCT_OF_SPAN,
        stop_se * PCT_OF_500LBF_PER_PCT_OF_SPAN,
        int(vf.slips.read.sum()),
    )


def load_amplitude_pct(record: Record, vf: ValveFit) -> float:
    """Amplitude of the external sine load at the process input, % of span, from an explicit fit.

    The sine and cosine are fitted beside the valve's regressors and the nuisances; their amplitude
    at PV is carried back through the process's gain at that frequency.
    """
    hyp = vf.hypothesis
    if not hyp.osc_period_s:
        return float("nan")
    tf = vf.tf
    omega = 2 * np.pi / hyp.osc_period_s
    t = record.t_s
    sines = record.compared(np.stack([np.sin(omega * t), np.cos(omega * t)]))
    nuisance = np.concatenate([record.compared(tf.free_responses(record.n)), np.ones((1, record.n_fit))])
    if hyp.linear_valve or vf.slips.at.size == 0:
        drive = drive_of(record.op_pct, hyp.actuator_tau_s, record.ts_s)
        model = record.compared_response(tf, drive.mean[None, :])
    else:
        model = record.compared_response(tf, path_regressors(vf.slips, record.n, record.ts_s, hyp.snapshot))
    y = record.target
    if not hyp.gain_free:
        y = y - vf.gain_ratio * model[0]
        model = model[1:]
    x = np.concatenate([sines, model, nuisance]).T
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    at_pv = float(np.hypot(coef[0], coef[1]))
    z = np.exp(-1j * omega * record.ts_s)
    response = abs(np.polyval(tf.b[::-1], z) / np.polyval(tf.a[::-1], z)) * abs(vf.gain_ratio)
    return at_pv / response if response > 0 else float("nan")


def stem_path(vf: ValveFit, record: Record) -> np.ndarray:
    """[N] the model's stem position (% of OP) at every interval: landings held between slips."""
    drive = drive_of(record.op_pct, vf.hypothesis.actuator_tau_s, record.ts_s)
    if vf.hypothesis.linear_valve:
        return drive.mean.copy()
    regs = path_regressors(vf.slips, record.n, record.ts_s, vf.hypothesis.snapshot)
    level0 = vf.level0_pct if np.isfinite(vf.level0_pct) else float(np.mean(record.op_pct))
    stop = vf.stop_pct if np.isfinite(vf.stop_pct) else 0.0
    jump = vf.jump_pct if np.isfinite(vf.jump_pct) else 0.0
    return regs[0] + stop * regs[1] + jump * regs[2] + level0 * regs[3]


def _still_valve_basis(vf: ValveFit, record: Record) -> np.ndarray:
    """[N, k] what the model draws with the stem held still: offset, drift, the process's initial state and, under
    the hypothesis of one, the external sine; fitted to the record's levels."""
    t = record.t_s / max(record.t_s[-1], 1e-9)
    x = np.stack([np.ones(record.n), t, *vf.tf.free_responses(record.n)], axis=1)
    if vf.hypothesis.osc_period_s:
        w = 2 * np.pi / vf.hypothesis.osc_period_s * record.t_s
        x = np.concatenate([x, np.sin(w)[:, None], np.cos(w)[:, None]], axis=1)
    return x


def _fitted(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    return x @ coef


def simulated_pv(vf: ValveFit, record: Record) -> np.ndarray:
    """[N] PV as the model simulates it from its stem path, with offset and drift fitted to the record's levels.

    Open loop in the process: what the model says PV did, not a one-sample prediction from the data.
    """
    u = stem_path(vf, record)
    # deviations from the first position: the process starts at rest with the stem where it is
    y = vf.gain_ratio * vf.tf.response(u[None, :] - u[0])[0]
    return y + _fitted(_still_valve_basis(vf, record), record.pv_pct - y)


def explained_share(vf: ValveFit, record: Record) -> float:
    """How much of PV's course the model's simulation from OP explains: 1 - its mean squared error over what the
    same model draws with the stem held still (offset, drift, initial state, an external sine, all fitted).  1: the
    valve's moves through the process explain PV's course; 0 or below: they explain none of it, and the model
    describes PV a sample ahead (its criterion) but not over the record.  NaN where PV has no course to explain."""
    x, pv, skip = _still_valve_basis(vf, record), record.pv_pct, record.skip
    still = float(np.mean((pv - _fitted(x, pv))[skip:] ** 2))
    model = float(np.mean((pv - simulated_pv(vf, record))[skip:] ** 2))
    if not still > 1e-12 * max(float(np.mean(pv[skip:] ** 2)), 1e-300):
        return float("nan")
    return 1.0 - model / still
