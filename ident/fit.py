"""Open-loop fits of the valve and the process to one measured loop, for one hypothesis.

A hypothesis fixes the process dynamics (``ident.process.Dynamics``), whether the process
gain is free, the actuator lag and an external oscillation's period.  Under it:

1. the stem's slips are read from PV (``ident.stem``);
2. the valve model says where the stem lands after each slip: ``drive - s * stop`` with
   ``drive`` the (lagged) OP when it slipped and ``s`` the slip's direction, and the
   interval of the slip withholds ``Fv/k`` seconds of flow per percent (``sim.valve``);
3. through the process, PV's change over the compared horizon is then linear in the
   gain ``g``, in ``g * stop`` and in the nuisances (initial state, a constant, the
   level before the first slip, an external sine): one least-squares solve gives all
   of them with their covariance (``ident.objective``'s variable projection).

The slips' times come from the data, not from an open-loop run of the valve: OP's
excursions in a closed loop are exactly what the real valve needed to slip, so a model
valve whose band is a hair too wide misses a slip and never catches up again (the
objective of a plain open-loop fit is a needle; see docs/measured-data.md).  The band
``S`` is read afterwards from the brackets every slip puts on it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ident.objective import nuisance_basis, project_out
from ident.process import Dynamics, TransferFunction, transfer_function
from ident.record import Record
from ident.stem import StemPath
from sim.valve import VALVE, lbf_to_pct, pct_to_lbf, stop_residual_in

SLIP_S = VALVE.viscous_lbf_s_per_in / VALVE.spring_lbf_per_in
"""Flow-time a slip of 1 % withholds (the stem's two time constants, ``sim.valve``)."""
PCT_OF_500LBF_PER_PCT = VALVE.lbf_per_pct * 100.0 / 500.0
"""S or stop in % of OP -> percent of 500 lbf (the thesis's fs/fd)."""


@dataclass(frozen=True)
class Hypothesis:
    dynamics: Dynamics = Dynamics()
    gain_free: bool = False
    actuator_tau_s: float = 0.0
    osc_period_s: float | None = None
    linear_valve: bool = False
    """No stiction: the stem follows the drive."""


@dataclass(frozen=True)
class LinearFit:
    rss: float
    n_params: int
    coef: np.ndarray
    cov: np.ndarray
    prediction: np.ndarray
    """Model of the compared signal."""
    sigma2: float


@dataclass(frozen=True)
class Drive:
    """The valve's drive: OP through the actuator's first-order lag (exact for OP held over each interval)."""

    end: np.ndarray
    """At the end of each interval."""
    mean: np.ndarray
    """Mean over each interval: where, on average, a slip during it breaks away."""


def drive_of(op_pct: np.ndarray, actuator_tau_s: float, ts_s: float) -> Drive:
    if actuator_tau_s <= 0:
        return Drive(op_pct.copy(), op_pct.copy())
    decay = np.exp(-ts_s / actuator_tau_s)
    end = np.empty_like(op_pct)
    d = op_pct[0]
    for k, op in enumerate(op_pct):
        d = op + (d - op) * decay
        end[k] = d
    start = np.concatenate([[op_pct[0]], end[:-1]])
    # mean of OP + (start - OP) e^(-t/tau) over the interval
    mean = op_pct + (start - op_pct) * actuator_tau_s / ts_s * (1 - decay)
    return Drive(end, mean)


def _with_deficit(r: np.ndarray, slips: np.ndarray, ts_s: float) -> np.ndarray:
    """The interval of a slip sees the mean stem position, ``Fv/k`` s of the jump short of the new level."""
    out = r.copy()
    ok = slips[slips > 0]
    out[..., ok] -= SLIP_S / ts_s * (r[..., ok] - r[..., ok - 1])
    return out


def path_regressors(path: StemPath, drive: Drive, n: int, ts_s: float) -> np.ndarray:
    """[3, N] input paths whose combination ``g*drive_at_slip - g*stop*direction + level0*first`` is the stem."""
    piece = np.searchsorted(path.slips, np.arange(n), side="right")
    at_slip = np.concatenate([[0.0], drive.mean[path.slips]])
    direction = np.concatenate([[0.0], path.directions.astype(float)])
    r = np.stack([at_slip[piece], direction[piece], (piece == 0).astype(float)])
    return _with_deficit(r, path.slips, ts_s)


def solve(y: np.ndarray, x: np.ndarray, q: np.ndarray) -> LinearFit:
    """Least squares of ``y`` [n] on the columns of ``x`` [p, n] after projecting out ``q`` [n, k]."""
    yp = project_out(y[None, :], q)[0]
    xp = project_out(x, q) if x.size else x
    if xp.shape[0]:
        coef, *_ = np.linalg.lstsq(xp.T, yp, rcond=None)
        fitted = coef @ xp
    else:
        coef, fitted = np.zeros(0), np.zeros_like(yp)
    resid = yp - fitted
    rss = float(resid @ resid)
    n_params = q.shape[1] + xp.shape[0]
    sigma2 = rss / max(y.size - n_params, 1)
    cov = sigma2 * np.linalg.pinv(xp @ xp.T) if xp.shape[0] else np.zeros((0, 0))
    return LinearFit(rss, n_params, coef, cov, y - resid, sigma2)


@dataclass(frozen=True)
class ValveFit:
    """One hypothesis fitted: the linear fit and what it says about the valve."""

    hypothesis: Hypothesis
    path: StemPath
    fit: LinearFit
    gain_ratio: float
    gain_se: float
    stop_pct: float
    stop_se: float
    tf: TransferFunction

    @property
    def rss(self) -> float:
        return self.fit.rss


def fit_valve(record: Record, hyp: Hypothesis, path: StemPath, nominal_gain: float = 1.0) -> ValveFit:
    tf = transfer_function(hyp.dynamics, record.ts_s)
    omega = 2 * np.pi / hyp.osc_period_s if hyp.osc_period_s else None
    q = nuisance_basis(record, tf, omega)
    drive = drive_of(record.op_pct, hyp.actuator_tau_s, record.ts_s)
    y = record.target
    if hyp.linear_valve:
        x = record.compared(tf.response(drive.mean[None, :]))
        if hyp.gain_free:
            fit = solve(y, x, q)
            g, g_se = float(fit.coef[0]), float(np.sqrt(fit.cov[0, 0]))
        else:
            fit = solve(y - nominal_gain * x[0], np.zeros((0, y.size)), q)
            fit = LinearFit(fit.rss, fit.n_params, fit.coef, fit.cov, fit.prediction + nominal_gain * x[0], fit.sigma2)
            g, g_se = nominal_gain, 0.0
        return ValveFit(hyp, path, fit, g, g_se, 0.0, 0.0, tf)
    x = record.compared(tf.response(path_regressors(path, drive, record.n, record.ts_s)))
    if hyp.gain_free:
        fit = solve(y, x, q)
        g, gs = fit.coef[0], fit.coef[1]
        stop = -gs / g if g != 0 else np.nan
        jac = np.array([gs / g**2, -1.0 / g])  # d stop / d (g, g*stop coefficient)
        stop_se = float(np.sqrt(max(jac @ fit.cov[:2, :2] @ jac, 0.0)))
        g_se = float(np.sqrt(fit.cov[0, 0]))
    else:
        fit = solve(y - nominal_gain * x[0], x[1:], q)
        fit = LinearFit(fit.rss, fit.n_params, fit.coef, fit.cov, fit.prediction + nominal_gain * x[0], fit.sigma2)
        g, g_se = nominal_gain, 0.0
        stop = -fit.coef[0] / g
        stop_se = float(np.sqrt(fit.cov[0, 0])) / abs(g)
    return ValveFit(hyp, path, fit, float(g), g_se, float(stop), stop_se, tf)


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


def _robust_se(x: np.ndarray) -> float:
    """Standard error of a median from the MAD (normal efficiency factor 1.25)."""
    mad = 1.4826 * np.median(np.abs(x - np.median(x)))
    return 1.25 * mad / np.sqrt(x.size)


def _band(stop: float, path: StemPath, drive: Drive) -> tuple[float, float, int]:
    """The band S from the slips' brackets, given where the stem landed: (median, its SE, slips read)."""
    slips, dirs = path.slips, path.directions
    if slips.size < 3:
        return np.nan, np.nan, 0
    landed = drive.mean[slips] - dirs * stop
    prev_level = landed[:-1]
    k = slips[1:]
    ok = k >= 1
    before = np.abs(drive.end[k[ok] - 1] - prev_level[ok])
    after = np.abs(drive.end[k[ok]] - prev_level[ok])
    mid = 0.5 * (before + after)
    if mid.size < 2:
        return np.nan, np.nan, 0
    return float(np.median(mid)), _robust_se(mid), int(mid.size)


def friction(vf: ValveFit, record: Record) -> Friction:
    """S from the brackets, J = S - stop, with the stop's uncertainty carried through."""
    drive = drive_of(record.op_pct, vf.hypothesis.actuator_tau_s, record.ts_s)
    s, s_se_brackets, n = _band(vf.stop_pct, vf.path, drive)
    if not np.isfinite(s) or not np.isfinite(vf.stop_pct):
        nan = float("nan")
        return Friction(nan, nan, nan, nan, nan, nan, nan, nan, n)
    eps = max(1e-3, 0.01 * abs(vf.stop_pct))
    ds = (_band(vf.stop_pct + eps, vf.path, drive)[0] - _band(vf.stop_pct - eps, vf.path, drive)[0]) / (2 * eps)
    s_se = float(np.hypot(s_se_brackets, ds * vf.stop_se))
    j = s - vf.stop_pct
    j_se = float(np.hypot(s_se_brackets, (ds - 1) * vf.stop_se))
    fs = s * PCT_OF_500LBF_PER_PCT
    stop_lbf = pct_to_lbf(vf.stop_pct * PCT_OF_500LBF_PER_PCT)
    fd_lbf = stop_lbf - VALVE.spring_lbf_per_in * stop_residual_in(pct_to_lbf(fs) - stop_lbf)
    fd = float(lbf_to_pct(fd_lbf))
    return Friction(
        float(s), float(j), s_se, j_se, float(fs), fd, s_se * PCT_OF_500LBF_PER_PCT,
        vf.stop_se * PCT_OF_500LBF_PER_PCT, n,
    )


REFINE_SHIFTS = (-2, -1, 1, 2)


def refine_slips(record: Record, hyp: Hypothesis, path: StemPath, nominal_gain: float = 1.0, sweeps: int = 2) -> StemPath:
    """Move each slip by up to two samples where that lowers the fit's residual (one slip at a time, batched).

    The segmentation reads slips through a smeared inverse (sensor lags, sampling zeros); under the
    hypothesis's exact model a slip placed a sample late costs a large residual at that sample.
    """
    if path.slips.size == 0 or hyp.linear_valve:
        return path
    tf = transfer_function(hyp.dynamics, record.ts_s)
    omega = 2 * np.pi / hyp.osc_period_s if hyp.osc_period_s else None
    q = nuisance_basis(record, tf, omega)
    drive = drive_of(record.op_pct, hyp.actuator_tau_s, record.ts_s)
    y = project_out(record.target[None, :], q)[0]
    slips = path.slips.copy()
    for _ in range(sweeps):
        variants, owners = [], []
        for j in range(slips.size):
            lo = slips[j - 1] + 1 if j else 1
            hi = slips[j + 1] - 1 if j + 1 < slips.size else record.n - 1
            for d in REFINE_SHIFTS:
                if lo <= slips[j] + d <= hi:
                    s = slips.copy()
                    s[j] += d
                    variants.append(s)
                    owners.append((j, d))
        if not variants:
            break
        all_slips = [slips, *variants]
        regs = np.stack([path_regressors(path.with_slips(s), drive, record.n, record.ts_s) for s in all_slips])
        x = project_out(record.compared(tf.response(regs)).reshape(-1, y.size), q).reshape(len(all_slips), 3, -1)
        if hyp.gain_free:
            target = np.broadcast_to(y, (len(all_slips), y.size))
            cols = x
        else:
            target = y[None, :] - nominal_gain * x[:, 0]
            cols = x[:, 1:]
        gram = np.einsum("bin,bjn->bij", cols, cols)
        rhs = np.einsum("bin,bn->bi", cols, target)
        coef = np.linalg.lstsq(gram[0], rhs[0], rcond=None)[0][None, :] if False else None
        coef = np.stack([np.linalg.lstsq(g, r, rcond=None)[0] for g, r in zip(gram, rhs, strict=True)])
        resid = target - np.einsum("bi,bin->bn", coef, cols)
        rss = np.einsum("bn,bn->b", resid, resid)
        best = {}
        for (j, d), r in zip(owners, rss[1:], strict=True):
            if r < rss[0] and (j not in best or r < best[j][1]):
                best[j] = (d, r)
        if not best:
            break
        # apply the independent improvements, keeping slips in order
        new = slips.copy()
        for j, (d, _) in best.items():
            new[j] += d
        if np.any(np.diff(new) <= 0):
            j = min(best, key=lambda k: best[k][1])
            new = slips.copy()
            new[j] += best[j][0]
        slips = new
    return path.with_slips(slips)
