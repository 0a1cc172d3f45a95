"""The valve-and-process model that is linear in its parameters once the slips are fixed.

Under a ``Hypothesis`` (process dynamics, actuator lag, external oscillation, a linear valve or
a sticky one), the stem lands after each slip at ``drive - s * stop``; PV's change over the
compared horizon is then linear in the gain, in ``gain * stop`` and in the nuisances, and
``solve`` gives all of them with their covariance.  ``ident.fit`` searches the slips and the
band with it; ``ident.friction`` reads the valve from its fits.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from stiction.ident import kernels
from stiction.ident.objective import project_out
from stiction.ident.process import Dynamics, TransferFunction
from stiction.ident.record import Record
from stiction.ident.stem import StemPath
from stiction.sim.valve import VALVE

SLIP_S = VALVE.viscous_lbf_s_per_in / VALVE.spring_lbf_per_in
"""Flow-time a slip of 1 % withholds (the stem's two time constants, ``sim.valve``)."""


@dataclass(frozen=True)
class Hypothesis:
    dynamics: Dynamics = Dynamics()
    gain_free: bool = False
    actuator_tau_s: float = 0.0
    osc_period_s: float | None = None
    linear_valve: bool = False
    """No stiction: the stem follows the drive."""
    snapshot: bool = False
    """The output samples the stem's position itself (a measured stem), not the flow it passed over an interval."""


@dataclass(frozen=True)
class Drive:
    """The valve's drive over each sample interval: OP through the actuator's first-order lag."""

    start: np.ndarray
    end: np.ndarray
    mean: np.ndarray
    moves: bool = False
    """Whether the drive moves within an interval (else it steps at the sample instants)."""
    decay: float = 0.0
    """``e^(-Ts/tau)``: the share of the gap to OP left at an interval's end (0: the drive steps)."""
    ts_s: float = 1.0
    """The sample time (the slide speed is per second)."""


def time_share(travel_share, decay: float):
    """``t / Ts`` at which a drive relaxing by ``decay`` an interval has covered ``travel_share`` of its travel:
    the drive relaxes exponentially, so a break halfway in travel comes before halfway in time."""
    if not 0.0 < decay < 1.0:
        return travel_share
    return np.log1p(-np.asarray(travel_share) * (1.0 - decay)) / np.log(decay)


def drive_of(op_pct: np.ndarray, actuator_tau_s: float, ts_s: float) -> Drive:
    """Exact for OP held over each interval: ``P(t) = OP + (P0 - OP) e^(-t/tau)``."""
    if actuator_tau_s <= 0:
        return Drive(op_pct, op_pct, op_pct)
    decay = np.exp(-ts_s / actuator_tau_s)
    end = np.empty_like(op_pct)
    # the drive when the record starts: a lag follows a ramp tau behind it
    m = min(5, op_pct.size - 1)
    d = op_pct[0] - actuator_tau_s * (op_pct[m] - op_pct[0]) / (m * ts_s) if m > 0 else op_pct[0]
    for k, op in enumerate(op_pct):
        d = op + (d - op) * decay
        end[k] = d
    start = np.concatenate([[op_pct[0]], end[:-1]])
    mean = op_pct + (start - op_pct) * actuator_tau_s / ts_s * (1 - decay)
    return Drive(start, end, mean, True, float(decay), float(ts_s))


@dataclass(frozen=True)
class Slips:
    """Where the stem slipped: interval indices, directions, and how far into the interval it broke away."""

    at: np.ndarray
    directions: np.ndarray
    breaks: np.ndarray
    """Fraction of the interval before the break (0: at the sample instant); negative for a stem that slides
    along a lagged drive (``ident.fit.walk``): it lands ``stop`` short of ``landing_drive`` as a held slip does,
    and minus this is the share of the interval that reads the old level."""
    landing_drive: np.ndarray
    """The drive when the stem broke away: it lands ``stop`` short of it."""
    read: np.ndarray
    """True where the data's segmentation found the slip, False where the valve model added it."""
    drive_offset: np.ndarray | None = None
    """Added to the slip's interval's flow (% of OP, known, the drive row): a stem that breaks away and slides
    on follows the drive, not its landing, for the rest of that interval.  Zeros where not given."""

    def __post_init__(self):
        if self.drive_offset is None:
            object.__setattr__(self, "drive_offset", np.zeros(np.shape(self.at)))

    @classmethod
    def from_path(cls, path: StemPath, drive: Drive) -> Slips:
        at = path.slips
        return cls(at, path.directions, np.zeros(at.size), drive.mean[at], np.ones(at.size, bool))


@dataclass(frozen=True)
class LinearFit:
    rss: float
    n_params: int
    coef: np.ndarray
    cov: np.ndarray
    prediction: np.ndarray
    """Model of the compared signal."""
    sigma2: float


def solve(y: np.ndarray, x: np.ndarray, q: np.ndarray) -> LinearFit:
    """Least squares of ``y`` [n] on the rows of ``x`` [p, n] after projecting out the columns of ``q`` [n, k]."""
    yp = project_out(y[None, :], q)[0]
    xp = project_out(x, q) if x.shape[0] else x
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


ROWS = ("drive", "stop", "jump", "level0")
"""The stem's position is ``drive_at_slip + stop * r_stop + jump * r_jump + level0 * r_level0``, per piece."""


def path_regressors(slips: Slips, n: int, ts_s: float, snapshot: bool = False) -> np.ndarray:
    """[4, N] the stem's flow as a linear combination of the valve's parameters (``ROWS``).

    After a slip at a held drive (OP steps at the sample instant) the stem lands ``stop`` short of
    the drive: ``M = p - d stop``.  When the drive moves within the interval (an actuator lag) it
    breaks away as the drive crosses ``M_old + d S`` and lands ``stop`` short of that point: it
    jumps by ``J = S - stop``, ``M = M_old + d J``, a chain back to the last held slip or to the
    level before the first slip.  Both are linear in (stop, J, level0): the least squares solve
    for them; the band S itself shows only in when the slips happen (``walk``).  The slip's own
    interval sees the old position until the break, then the new one, less the slip's deficit.
    One set of slips: ``path_regressors_many``, which builds every set's pieces at once.
    """
    return path_regressors_many([slips], n, ts_s, snapshot)[0]


def path_regressors_many(many: list[Slips], n: int, ts_s: float, snapshot: bool = False) -> np.ndarray:
    """[V, 4, N] ``path_regressors`` of every slip set at once (the searches fit dozens a step): each
    slip's piece runs from the last slip at a held drive (or the level before the first slip) on, plus
    the jumps of the slips at a moving drive since then.  Compiled (``ident.kernels.path_regressors``);
    the tests hold it to a slip-by-slip transcription."""
    v_count, m = len(many), max((s.at.size for s in many), default=0)
    at = np.full((v_count, m), n, np.int64)
    d, breaks, landing = np.zeros((v_count, m)), np.zeros((v_count, m)), np.zeros((v_count, m))
    offset = np.zeros((v_count, m))
    counts = np.zeros(v_count, np.int64)
    for v, s in enumerate(many):
        k = counts[v] = s.at.size
        at[v, :k], d[v, :k], breaks[v, :k], landing[v, :k] = s.at, s.directions, s.breaks, s.landing_drive
        offset[v, :k] = s.drive_offset
    return kernels.path_regressors(at, d, breaks, landing, offset, counts, int(n), SLIP_S / ts_s, bool(snapshot))


@dataclass(frozen=True)
class ValveFit:
    """One hypothesis fitted: the linear fit and what it says about the valve (percent of OP)."""

    hypothesis: Hypothesis
    slips: Slips
    fit: LinearFit
    gain_ratio: float
    gain_se: float
    stop_pct: float
    stop_se: float
    level0_pct: float
    """The stem's position before the first slip."""
    tf: TransferFunction
    band_pct: float = np.nan
    """S, % of OP."""
    band_se: float = np.nan
    jump_pct: float = np.nan
    """J as the least squares read it from slips at a moving drive (nan: none such)."""
    jump_se: float = np.nan

    @property
    def rss(self) -> float:
        return self.fit.rss

    @property
    def n_params(self) -> int:
        """Linear parameters, the hypothesis's own, and one per slip the valve model did not make itself."""
        return self.fit.n_params + own_params(self.hypothesis) + int(self.slips.read.sum())


def solved_rows(hyp: Hypothesis) -> list[int]:
    """Which of ``ROWS`` the least squares solve for: the jump only where the drive moves within intervals."""
    rows = [0] if hyp.gain_free else []
    return rows + [1, 2, 3] if hyp.actuator_tau_s > 0 else rows + [1, 3]


def linear_fit(record: Record, hyp: Hypothesis, x: np.ndarray, q: np.ndarray, nominal_gain: float) -> LinearFit:
    """Least squares on the compared regressors ``x`` [4, n]; a fixed gain moves ``x[0]`` to the target's side.

    The coefficients come back for all four ``ROWS`` (``g`` times each parameter), zero where not solved.
    """
    rows = solved_rows(hyp)
    y = record.target if hyp.gain_free else record.target - nominal_gain * x[0]
    fit = solve(y, x[rows], q)
    coef = np.zeros(4)
    cov = np.zeros((4, 4))
    coef[rows] = fit.coef
    cov[np.ix_(rows, rows)] = fit.cov
    if not hyp.gain_free:
        coef[0] = nominal_gain
    prediction = fit.prediction if hyp.gain_free else fit.prediction + nominal_gain * x[0]
    return replace(fit, coef=coef, cov=cov, prediction=prediction)


@dataclass(frozen=True)
class Coefficients:
    gain: float
    gain_se: float
    stop: float
    stop_se: float
    level0: float
    jump: float
    jump_se: float


def valve_from_fit(fit: LinearFit) -> Coefficients:
    """The valve's parameters from the coefficients of ``g * (drive, stop, jump, level0)``; nan where not solved.

    Only slips at a held drive read ``stop`` (and the gain, through the drive's level), only slips
    at a moving drive read ``J``.
    """
    c, cov = fit.coef, fit.cov
    g = float(c[0])
    g_se = float(np.sqrt(max(cov[0, 0], 0.0)))
    nan = float("nan")
    if g == 0:
        return Coefficients(0.0, g_se, nan, nan, nan, nan, nan)

    def ratio(i):
        if cov[i, i] <= 0 and c[i] == 0:
            return nan, nan
        jac = np.zeros(4)
        jac[0], jac[i] = -c[i] / g**2, 1.0 / g  # d (c_i / g)
        return float(c[i] / g), float(np.sqrt(max(jac @ cov @ jac, 0.0)))

    stop, stop_se = ratio(1)
    jump, jump_se = ratio(2)
    level0, _ = ratio(3)
    return Coefficients(g, g_se, stop, stop_se, level0, jump, jump_se)


def own_params(hyp: Hypothesis) -> int:
    d = hyp.dynamics
    return (
        int(d.time_constant_s is not None)
        + int(d.dead_time_s > 0)
        + int(d.sensor_tau_s > 0)
        + int(hyp.actuator_tau_s > 0)
        + int(hyp.osc_period_s is not None)
    )
