"""The valve fitted to the whole record of a level loop, driven open loop by its recorded OP (output error): the
fitted reading, which ``quantify.pipeline`` shows in the physical block.

The physical reading (``quantify.physical``) reads the stem from PV's steps, ``15 s * dPV``: a measurement
noise on PV is differenced there, and beyond a few tenths of a percent it hides the slips (the readings'
errors exceed their trust and the learned ensemble speaks, 2.1 pp off on average on the thesis's noisy random
loops).  Here the noise is not differenced.  OP is recorded as the controller wrote it, and for a known level
loop (``PV' = MV / 15 s``, spec/thesis-loop.md) the stem the valve makes of it is a deterministic function of
the recorded OP and the friction: a valve driven by a record of OP is not the chaotic closed loop, it is an
open-loop recursion.  So each candidate (fs, fd) gives a level, the recorded OP's stem integrated, and the
candidates whose level leaves PV the smallest residual give the reading.

- The residual is jagged in fs and fd: a candidate 0.1 % of 500 lbf off moves one breakaway by a sample, and the
  level, an integral, keeps the offset.  The search runs coarse to fine on residuals with a free offset in
  every stretch of ``COARSE_SEGMENT`` and ``MEDIUM_SEGMENT`` samples (a late offset costs only its stretch) and
  ends on the whole window, from the best few candidates of each stage.
- The stem's start is not known, and it is not forgotten: a start a hundredth of the band off moves the first
  breakaway by a sample, which moves every landing after it.  But a stem stuck anywhere holds still until its
  first breakaway and then lands where that sample's OP puts it, so the start is one of the samples OP can first
  break away at (``first_breakaways``), not a number: each candidate is tried from each (up to ``MAX_EVENTS``),
  PV before it held to a line (the still stem's flow) and after it to the valve's level.
- The whole window's residual is held about a line (``RAMP``): an inflow the outflow does not balance, and the
  drift a friction a few hundredths of a percent off leaves.
- **The model must explain the record** (``Fit.accepted``).  The fitted stem must slip (``MIN_SLIPS``), and
  what the fit leaves must be the measurement's white noise: its variance within ``MAX_VARIANCE_RATIO`` of the
  noise's (read from PV's second differences, robustly: a slip is one sample in many), and no periodic part in it
  (``MAX_PEAK_SHARE``: Fisher's test of a periodogram's largest ordinate).
- **A cycle of a load.**  A sine on PV, or on the process input (which the level integrates into a sinusoid of the
  same frequency), leaves a periodic residual: that sinusoid is taken out of PV and the valve fitted again
  (``fit_window``), and the reading accepted where the two leave next to nothing (``MAX_UNEXPLAINED``).  The
  cycle is read off the first fit's residual, so only where the valve nearly explains the record already.  Another
  valve or process: the residual says so, and the reading is withheld.
- **The reading is the middle of the best, not the best.**  Over a range of fs the stem breaks away at the same
  samples, and the residual there is flat but for PV's noise: its argmin moves with the last bits of PV.  The
  reading is the median of the last stage's candidates within the 95 % band of the residual's chi-square (on the
  design seeds fs's mean error 0.116 -> 0.087 pp, fd's unchanged); the residual and the acceptance are read at the
  best (``Fit.best``).
- **A wandering inflow.**  A random walk on the process input is a random walk's integral on the level: its
  second differences are white, the level's are not.  Where neither fit above is accepted, the valve is fitted on
  the residual's second differences (``Fit.order`` 2: the least squares of that noise, the slips' sizes and times),
  and accepted where those are the noise's and white (``MAX_VARIANCE_RATIO``, ``MAX_PEAK_SHARE``, ``MAX_LAG1``).
  On the design seeds it accepted 71 more of 294 (errors' medians 0.039 / 0.012 pp, 95th percentiles 0.36 / 0.097;
  69 within two of their errors, ``DIFFERENCED_MIN_SE_PCT``), where the readings it replaces were off by 0.74 pp
  on average.
- **A check on the slips' reading.**  Where the slips' reading is trusted, ``explains`` asks whether the valve at
  that reading explains the record as a fit must; where it does not, ``stiction quantify`` fits the valve too
  (``quantify.pipeline``), and an accepted fit is the reading.  On the design seeds (3131-3133) 26 of 306 trusted
  slip readings fell outside two of their errors (up to 2.9 pp off under a load's sine); at the truth the model
  explains most of those records.
- Its standard errors are those the medium stage's profile gives (the candidates within the 95 % band of
  the residual's chi-square), never under ``MIN_SE_PCT`` (fd: ``SINUSOID_MIN_FD_SE_PCT``): the profile of a jagged
  residual is narrower than the reading's error, and on the design seeds the floor is what holds the truth.

Constants chosen on random loops of seeds 3131-3133 (docs/benchmarks.md, "The fitted reading"); ``stiction
bench accuracy``'s sets judged after.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from stiction.detect.oscillation import autocorrelation
from stiction.ident.open_loop_kernel import event_rss
from stiction.ident.stem import second_difference_sd
from stiction.sim.process import LOOPS
from stiction.sim.valve import Friction, pct_to_lbf

LEVEL_GAIN_PER_S = LOOPS["level"].gain
RAMP = True
"""The whole window's residual (the last stage, and what the acceptance reads) is held about a line: a constant flow
the valve does not make (an inflow the outflow does not balance), and the lasting drift a friction a few hundredths
of a percent off leaves."""
MAX_EVENTS = 24
"""The most first breakaways (``first_breakaways``) a candidate is tried from, evenly spaced in their order where OP
makes more (a slow OP under a wide band makes one at every sample it reaches a new high or low).  On the design
seeds (3131-3133) 24 accepted 189 readings where 64 accepted 190, in three quarters of the time."""
CAP_RATIO = 2.0
"""Around a candidate (the medium and last stages), those whose residual is twice the best before them are left
unfinished: the search reads only the best few and the profile (within 0.4 % of the best at 1,000 samples)."""
COARSE_STEP_PCT = 1.0
COARSE_SEGMENT = 25
MEDIUM_STEP_PCT = 0.1
MEDIUM_HALF_PCT = 2.0
MEDIUM_SEGMENT = 100
POLISH_STEP_PCT = 0.02
POLISH_HALF_PCT = 0.3
REFINE_STEP_PCT = 0.005
REFINE_HALF_PCT = 0.05
REFINE_ROUNDS = 4
"""After the last stage, the best candidate is searched around on a finer grid, recentred while it improves.  A small
band that slips often leaves a residual whose valley is narrower than ``POLISH_STEP_PCT``: the stem's slips move a
sample when fs moves a hundredth of a percent (design seed 3133, loop 31: the residual's variance 0.93 of the noise's
at fs 4.68, 3.4 at 4.67).  Where it moved, the last stage's grid is searched again around it (the reading is the
median of that grid's candidates within the band)."""
SEEDS = 5
"""Local minima of the coarse stage taken on (beside the readings given as ``extra``)."""
KEEP = 4
"""Candidates of the medium stage polished."""
MAX_FS_PCT = 100.0
MAX_VARIANCE_RATIO = 2.5
MAX_PEAK_SHARE = 0.05
MIN_SLIPS = 4
"""The fitted stem must slip this often in the window (each way twice): a stem stuck all window fits any fd and
bounds fs only from below (a band of 54 % of span under an input sine, seed 3131, fitted to 0.02 % of PV's
variance with no slip and fd 18 off)."""
SINUSOID_ROUNDS = 3
MIN_CYCLES = 2
"""A load's cycle taken out of PV completes at least this many cycles in the window: slower, a poor fit's drift
(the largest part of a wrong fit's residual) would be taken for it."""
SINUSOID_STEPS = 81
MAX_UNEXPLAINED = 0.05
"""With a sinusoid taken out: the most of PV's standard deviation the residual may keep."""
MAX_LEFT_SHARE = 0.2
"""With a sinusoid taken out and what is left not white: the most of the residual's variance the sinusoid may leave.
A load's cycle is one line of the spectrum; a random walk on PV or the level's integral of a white inflow spreads
over the low frequencies, and one sinusoid takes a part of it.  On the design seeds (3131-3133), with every trusted
slip reading also fitted, the fits accepted by ``MAX_UNEXPLAINED`` alone left 0.000-0.57 (median 0.006) under a
load's sine, and 0.24-0.84 (median 0.6) under those noises, where 9 of 51 fell outside two errors."""
EXACT_UNEXPLAINED = 1e-3
"""A record the model and a sinusoid reproduce within this share of PV's standard deviation is explained whatever
the share left (``MAX_LEFT_SHARE``): a noise-free record's residual is rounding, and a sinusoid takes none of it."""
SINUSOID_MIN_FD_SE_PCT = 0.08
"""The least standard error of fd in a reading with a sinusoid taken out (its fs keeps ``MIN_SE_PCT``'s 0.4): on the
34 accepted of the design seeds the errors' 95th percentiles were 0.41 (fs) and 0.15 (fd), medians 0.09 and 0.007."""
MIN_SE_PCT = (0.4, 0.05)
"""The least standard errors (fs, fd): on the 53 accepted readings of the design seeds (3131-3133) the errors' 95th
percentiles were 0.80 and 0.066 (medians 0.11 and 0.01), where the profile gave 0.1-0.4 and 0.1-0.13: two of
these hold about 95 % of the truth.  With the start read as the first breakaway (193 accepted, both kinds) the 95th
percentiles are 0.34 and 0.10, and two errors hold both for 187 of 193."""

DIFFERENCED_MIN_SE_PCT = (0.4, 0.1)
"""The least standard errors (fs, fd) of a fit on second differences (``Fit.order`` 2): its information is the
slips' sizes and times alone.  On the 71 such readings of the design seeds (3131-3133) the errors' medians were
0.039 and 0.012, their 95th percentiles 0.36 and 0.097, the largest 0.70 and 0.47; with ``MIN_SE_PCT``'s floors
4 fell outside two errors, with these 2."""
FEW_SLIPS = 20
"""The least errors (``MIN_SE_PCT``, ``DIFFERENCED_MIN_SE_PCT``, ``SINUSOID_MIN_FD_SE_PCT``) were set on readings of
20 slips and more (the 5th percentile of the 193 the design seeds 3131-3133 accepted; median 41).  A reading of
fewer is read off fewer events: its least errors grow as ``sqrt(FEW_SLIPS / slips)``.  On 22 accepted readings of
4-12 slips (design seeds 3134-3188, loops whose stem moved 1-11 times), 5 fell outside two errors before, 1 after."""
MAX_LAG1 = 0.2
"""A fit on second differences (``Fit.order`` 2) leaves them white only where PV's noise is a random walk's
integral: a white measurement noise leaves a lag-one correlation of -2/3, a random walk on PV -1/2.  On the design
seeds (3131-3133) the 71 wandering inflows it accepted left -0.06 to 0.07; the 13 other records it would have
accepted without this test (white noise on PV, random walks on PV or on the inflow) -0.40 to -0.66, one of them
1.1 pp off in fs and fd."""


@dataclass(frozen=True)
class FittedReading:
    """Arrays over windows, percent of 500 lbf; nan where not fitted."""

    fs_pct: np.ndarray
    fd_pct: np.ndarray
    fs_se_pct: np.ndarray
    fd_se_pct: np.ndarray
    variance_ratio: np.ndarray
    """The residual's variance over the measurement noise's."""
    peak_share: np.ndarray
    """The residual periodogram's largest ordinate over their sum."""
    accepted: np.ndarray
    """The model explains the record (``Fit.accepted``): the reading may speak."""
    slips: np.ndarray
    """How many times the fitted stem slipped in the window."""
    sinusoid_rad_s: np.ndarray
    """The frequency of the sinusoid taken out of PV; nan where none was."""


def stem_path(op: np.ndarray, fs_pct: float, fd_pct: float, mv0_pct: float, ts_s: float = 1.0,
              gain_per_s: float = LEVEL_GAIN_PER_S) -> np.ndarray:  # fmt: skip
    """[N] the level (from 0) the recorded ``op`` makes through a valve of friction ``fs_pct``, ``fd_pct`` whose stem
    starts stuck at ``mv0_pct``, one sample at a time: the model the simulator is held to (``breakaway_residual`` is
    the same valve from its first breakaway)."""
    return _path(op, fs_pct, fd_pct, mv0_pct, ts_s, gain_per_s)[0]


def _path(op, fs_pct, fd_pct, mv0_pct, ts_s, gain_per_s) -> tuple[np.ndarray, int]:
    """``stem_path`` and how many times the stem slipped."""
    fr = Friction.physical(pct_to_lbf(np.array([fs_pct])), pct_to_lbf(np.array([fd_pct])))
    level, mv, out, slips = 0.0, float(mv0_pct), np.empty(len(op)), 0
    for k, drive in enumerate(np.asarray(op, float)):
        out[k] = level
        force = fr.lbf_per_pct * (drive - mv)
        flow = mv
        if abs(force) > fr.fs_lbf[0]:
            jump = (force - np.sign(force) * fr.stop_lbf[0]) / fr.lbf_per_pct
            mv += jump
            flow = mv - jump * fr.slip_s / ts_s
            slips += 1
        level += gain_per_s * ts_s * flow
    return out, slips


def first_breakaways(op: np.ndarray, band_pct: float) -> list[tuple[int, int]]:
    """The samples (and directions, +1 up) at which a stem stuck somewhere within ``band_pct`` of OP at the window's
    start can first break away: those where OP reaches a new high or low while OP so far spans less than two bands
    (a stem can then sit where it has not yet broken away and breaks away now).  The definition
    ``open_loop_kernel.breakaways`` is held to."""
    out, hi, lo = [], -np.inf, np.inf
    for k, x in enumerate(np.asarray(op, float)):
        if hi - lo >= 2 * band_pct:
            break
        if x > hi:
            out.append((k, 1))
        if x < lo:
            out.append((k, -1))
        hi, lo = max(hi, x), min(lo, x)
    return out


def breakaway_residual(op, pv, fs_pct: float, fd_pct: float, k1: int, direction: int, segment: int | None = None,
                       ramp: bool = False, ts_s: float = 1.0, gain_per_s: float = LEVEL_GAIN_PER_S,
                       order: int = 0) -> tuple[np.ndarray, int]:  # fmt: skip
    """PV less the candidate's level from a first breakaway at sample ``k1`` (``direction``), and how many times its
    stem slipped: up to ``k1`` the stem is still and PV is held to its own least-squares line; after it, the stem
    lands where that sample's OP puts it and the level it makes is held to PV with a free offset in every stretch
    of ``segment`` samples from ``k1 + 1`` (the rest of the window for None; ``ramp``: a free line).  ``order`` 2:
    the second differences of both parts instead (not across ``k1``).  The definition ``open_loop_kernel.event_rss``
    is held to."""
    op, pv = np.asarray(op, float), np.asarray(pv, float)
    fr = Friction.physical(pct_to_lbf(np.array([fs_pct])), pct_to_lbf(np.array([fd_pct])))
    head = pv[: k1 + 1]
    landing = op[k1] - direction * fr.stop_lbf[0] / fr.lbf_per_pct
    after, slips = _path(op[k1 + 1 :], fs_pct, fd_pct, landing, ts_s, gain_per_s)
    tail = pv[k1 + 1 :] - after
    if order == 2:
        return np.concatenate([np.diff(head, 2), np.diff(tail, 2)]), slips + 1
    step = segment or max(tail.size, 1)
    pieces = [_detrended(p, ramp) for p in np.array_split(tail, np.arange(step, tail.size, step))] if tail.size else []
    still = _detrended(head, True) if head.size >= 3 else np.zeros(head.size)
    return np.concatenate([still, *pieces]), slips + 1


def _detrended(x: np.ndarray, ramp: bool) -> np.ndarray:
    """``x`` less its mean, or (``ramp``, three samples or more) less its least-squares line."""
    if ramp and x.size >= 3:
        t = np.arange(x.size)
        return x - np.polyval(np.polyfit(t, x, 1), t)
    return x - x.mean()


def _rss(op, pv, grid, segment, ts_s, gain_per_s, ramp=False, cap_ratio=np.inf, order=0) -> tuple[np.ndarray, ...]:
    """[C] each candidate's residual over its first breakaways (``event_rss``; inf beyond ``cap_ratio`` times the
    best before it; ``order`` 2: of the residual's second differences), and the best one's sample and direction."""
    fr = Friction.physical(pct_to_lbf(grid[:, 0]), pct_to_lbf(grid[:, 1]))
    return event_rss(op, pv, fr.fs_lbf, fr.stop_lbf, fr.slip_s / ts_s, gain_per_s * ts_s, fr.lbf_per_pct, segment,
                     MAX_EVENTS, ramp, cap_ratio, order)  # fmt: skip


def _around(centre, half: float, step: float) -> np.ndarray:
    """The candidates (fs, fd) of a square grid around ``centre`` that a valve can have (0 <= fd < fs <= max),
    nearest the centre first (``CAP_RATIO`` leaves those far worse than the best before them unfinished)."""
    axis = np.arange(-half, half + step / 2, step)
    fs, fd = np.meshgrid(centre[0] + axis, centre[1] + axis, indexing="ij")
    grid = np.column_stack([fs.ravel(), fd.ravel()])
    keep = (grid[:, 1] >= 0) & (grid[:, 1] < grid[:, 0]) & (grid[:, 0] <= MAX_FS_PCT)
    grid = grid[keep]
    return grid[np.argsort(np.max(np.abs(grid - np.asarray(centre, float)), axis=1), kind="stable")]


@lru_cache(maxsize=1)
def _coarse_grid() -> np.ndarray:
    """The coarse stage's candidates (built once: every fit and every round of ``fit_window`` searches them)."""
    fs = np.arange(COARSE_STEP_PCT, MAX_FS_PCT + COARSE_STEP_PCT / 2, COARSE_STEP_PCT)
    grid = np.array([(a, b) for a in fs for b in np.arange(0.0, a, COARSE_STEP_PCT)])
    grid.flags.writeable = False
    return grid


def _minima(grid: np.ndarray, rss: np.ndarray, count: int, apart: float) -> list[np.ndarray]:
    """The ``count`` best candidates at least ``apart`` from each other (in fs or fd)."""
    out: list[np.ndarray] = []
    for i in np.argsort(rss):
        if all(np.max(np.abs(grid[i] - c)) > apart for c in out):
            out.append(grid[i])
        if len(out) == count:
            break
    return out


def peak_share(residual: np.ndarray) -> float:
    """The largest ordinate of the residual's periodogram over their sum (Fisher's g): about ``ln(n/2) / (n/2)``
    for white noise (1.2 % at 1,000 samples), most of it for a sine."""
    r = np.asarray(residual, float) - np.mean(residual)
    power = np.abs(np.fft.rfft(r)[1:]) ** 2
    return float(power.max() / power.sum()) if power.sum() > 0 else 0.0


def _best_start_residual(op, pv, fs_pct, fd_pct, ts_s, gain_per_s, order=0) -> tuple[np.ndarray, int]:
    """PV less the level of the candidate's best first breakaway (over the whole window; ``order`` 2: the second
    differences of that), and the slips of that path."""
    _, k1, direction = _rss(op, pv, np.array([[fs_pct, fd_pct]]), op.size, ts_s, gain_per_s, RAMP, order=order)
    return breakaway_residual(op, pv, fs_pct, fd_pct, int(k1[0]), int(direction[0]), None, RAMP, ts_s, gain_per_s,
                              order)  # fmt: skip


def few_slips_widening(slips: int) -> float:
    """How much wider a reading's least errors are for its ``slips`` (``FEW_SLIPS``): 1 from ``FEW_SLIPS`` up."""
    return float(np.sqrt(FEW_SLIPS / slips)) if 0 < slips < FEW_SLIPS else 1.0


def lag_one(residual: np.ndarray) -> float:
    """The lag-one autocorrelation of ``residual`` about its mean (``detect.oscillation.autocorrelation``): about 0
    (within 1/sqrt(n)) for white noise; 0 for a residual that is all zero."""
    r = float(autocorrelation(residual, 1)[0, 1])
    return r if np.isfinite(r) else 0.0


def peak_frequency(x: np.ndarray) -> float:
    """The angular frequency (rad a sample) of the largest periodogram peak of ``x`` from ``MIN_CYCLES`` cycles a
    window up, refined within a bin either side (the sinusoid that takes most out)."""
    r = np.asarray(x, float) - np.mean(x)
    n = r.size
    k = int(np.argmax(np.abs(np.fft.rfft(r)[MIN_CYCLES:]) ** 2)) + MIN_CYCLES
    omegas = 2 * np.pi * np.linspace(k - 1, k + 1, SINUSOID_STEPS) / n
    return float(max(omegas, key=lambda omega: float(np.sum(sinusoid(r, omega) ** 2))))


def sinusoid(residual: np.ndarray, omega: float) -> np.ndarray:
    """The least-squares sinusoid of angular frequency ``omega`` (rad a sample) in ``residual`` (with its mean)."""
    r = np.asarray(residual, float)
    t = np.arange(r.size)
    basis = np.column_stack([np.sin(omega * t), np.cos(omega * t), np.ones(r.size)])
    coef = np.linalg.lstsq(basis, r, rcond=None)[0]
    return basis[:, :2] @ coef[:2]


@dataclass(frozen=True)
class Fit:
    """One window's fitted reading (percent of 500 lbf) and what tells whether the model explains the record."""

    fs_pct: float
    fd_pct: float
    fs_se_pct: float
    fd_se_pct: float
    variance_ratio: float
    peak_share: float
    slips: int
    sinusoid_rad_s: float = np.nan
    """The frequency of the sinusoid taken out of PV (a load's cycle: ``fit_window``), nan for none."""
    unexplained: float = np.nan
    """With a sinusoid taken out: the residual's RMS over PV's standard deviation."""
    best: tuple[float, float] = (np.nan, np.nan)
    """The candidate (fs, fd) that leaves the least residual: the residual, the slips and the sinusoid are read there.
    The reading (``fs_pct``, ``fd_pct``) is the median of the candidates within the 95 % band of its residual."""
    order: int = 0
    """The noise the fit took PV to carry: 0 white, 2 a random walk's integral (a wandering inflow; fitted on the
    residual's second differences)."""
    lag1: float = np.nan
    """The lag-one autocorrelation of what the fit leaves (read where ``order`` is 2)."""
    left_share: float = np.nan
    """With a sinusoid taken out: the share of the residual's variance it leaves."""

    @property
    def accepted(self) -> bool:
        """The model explains the record: the stem slipped (``MIN_SLIPS``), and what is left is white noise
        (``MAX_VARIANCE_RATIO``, ``MAX_PEAK_SHARE``) or, with a sinusoid taken out, white noise or next to nothing
        (``MAX_UNEXPLAINED``: a second periodic part is then at most that large) where the sinusoid took out most
        of the residual (``MAX_LEFT_SHARE``)."""
        if self.slips < MIN_SLIPS:
            return False
        white = self.variance_ratio <= MAX_VARIANCE_RATIO and self.peak_share <= MAX_PEAK_SHARE
        if self.order == 2:  # a white noise's second differences are not white: their lag-one correlation is -2/3
            return bool(white and abs(self.lag1) <= MAX_LAG1)
        if np.isfinite(self.sinusoid_rad_s):
            cycle = self.left_share <= MAX_LEFT_SHARE or self.unexplained <= EXACT_UNEXPLAINED
            return bool(white or (self.unexplained <= MAX_UNEXPLAINED and cycle))
        return bool(white)


def fit_one(op, pv, ts_s: float = 1.0, gain_per_s: float = LEVEL_GAIN_PER_S, extra=(), coarse: bool = True,
            order: int = 0) -> Fit:  # fmt: skip
    """The valve fitted to one window (no sinusoid); ``extra``: readings (fs, fd) to search around beside the coarse
    stage's minima (the physical reading beyond its trust, the learned one); ``coarse``: False searches around
    ``extra`` alone; ``order`` 2: fitted on the residual's second differences (``Fit.order``)."""
    op, pv = np.asarray(op, float), np.asarray(pv, float)
    n = op.size
    seeds = []
    if coarse:
        grid = _coarse_grid()
        coarse_rss = _rss(op, pv, grid, COARSE_SEGMENT, ts_s, gain_per_s, order=order)[0]
        seeds = _minima(grid, coarse_rss, SEEDS, 3 * COARSE_STEP_PCT)
    seeds += [np.asarray(e, float) for e in extra if np.all(np.isfinite(e)) and 0 <= e[1] < e[0] <= MAX_FS_PCT]
    medium = []
    for centre in seeds:
        grid = _around(centre, MEDIUM_HALF_PCT, MEDIUM_STEP_PCT)
        rss = _rss(op, pv, grid, MEDIUM_SEGMENT, ts_s, gain_per_s, cap_ratio=CAP_RATIO, order=order)[0]
        medium += [(rss[i], grid[i], grid, rss) for i in np.argsort(rss)[:2]]
    medium.sort(key=lambda m: m[0])
    best = (np.inf, None, None)
    for _, centre, grid, rss in medium[:KEEP]:
        fine = _around(centre, POLISH_HALF_PCT, POLISH_STEP_PCT)
        fine_rss = _rss(op, pv, fine, n, ts_s, gain_per_s, RAMP, CAP_RATIO, order)[0]
        i = int(np.argmin(fine_rss))
        if fine_rss[i] < best[0]:
            best = (fine_rss[i], fine[i], (grid, rss), (fine, fine_rss))
    rss_min, (fs, fd), (grid, rss), (fine, fine_rss) = best
    moved = False
    for _ in range(REFINE_ROUNDS):
        near = _around((fs, fd), REFINE_HALF_PCT, REFINE_STEP_PCT)
        near_rss = _rss(op, pv, near, n, ts_s, gain_per_s, RAMP, CAP_RATIO, order)[0]
        i = int(np.argmin(near_rss))
        if not near_rss[i] < rss_min:
            break
        rss_min, (fs, fd), moved = near_rss[i], near[i], True
    if moved:  # the band's candidates on the last stage's grid, around the best found
        fine = _around((fs, fd), POLISH_HALF_PCT, POLISH_STEP_PCT)
        fine_rss = _rss(op, pv, fine, n, ts_s, gain_per_s, RAMP, CAP_RATIO, order)[0]
    # the reading: the median of the last stage's candidates within chi-square's 95 % band of its best
    reading = np.median(fine[fine_rss <= rss_min * (1 + 3.84 / (n - 4))], axis=0)
    if not 0 <= reading[1] < reading[0]:
        reading = (fs, fd)
    # the medium stage's profile: the candidates within chi-square's 95 % band of its best
    s2 = rss.min() / (n - 4 if order == 2 else n - n // MEDIUM_SEGMENT - 2)
    inside = grid[rss <= rss.min() + 3.84 * s2]
    residual, slips = _best_start_residual(op, pv, fs, fd, ts_s, gain_per_s, order)
    floor = np.asarray(DIFFERENCED_MIN_SE_PCT if order == 2 else MIN_SE_PCT) * few_slips_widening(slips)
    se = np.maximum(np.ptp(inside, axis=0) / (2 * 1.96), floor)
    sd = second_difference_sd(pv)  # the white noise only: no floor for a stepped record (ident.stem.pv_noise_sd)
    # the residual's variance over the noise's: a white noise's second differences have six times its variance, an
    # integrated random walk's are its steps
    ratio = rss_min / ((n - 4) * 6 * sd**2 if order == 2 else n * sd**2) if sd > 0 else np.inf
    return Fit(float(reading[0]), float(reading[1]), float(se[0]), float(se[1]), float(ratio), peak_share(residual),
               slips, best=(float(fs), float(fd)), order=order, lag1=lag_one(residual))  # fmt: skip


def fit_window(op, pv, ts_s: float = 1.0, gain_per_s: float = LEVEL_GAIN_PER_S, extra=()) -> Fit:
    """``fit_one``; where what it leaves has a periodic part, the valve fitted beside a load's cycle
    (``_with_sinusoid``); where neither is accepted, the valve fitted on the residual's second differences
    (``order`` 2: a wandering inflow), accepted where those are the noise's."""
    op, pv = np.asarray(op, float), np.asarray(pv, float)
    first = fit_one(op, pv, ts_s, gain_per_s, extra)
    if first.accepted:
        return first
    fit = first
    if first.peak_share > MAX_PEAK_SHARE:
        fit = _with_sinusoid(op, pv, first, extra, ts_s, gain_per_s)
        if fit.accepted:
            return fit
    wandering = fit_one(op, pv, ts_s, gain_per_s, [*extra, first.best], order=2)
    return wandering if wandering.accepted else fit


def _with_sinusoid(op, pv, first: Fit, extra, ts_s: float, gain_per_s: float) -> Fit:
    """A load's cycle on PV or on the process input (which the level carries as a sinusoid of the load's frequency):
    that sinusoid is taken out of PV and the valve fitted again, ``SINUSOID_ROUNDS`` times, each round's sinusoid
    read off the last fit's residual (its largest periodogram peak).  Such a reading is accepted where the model and
    the sinusoid leave at most ``MAX_UNEXPLAINED`` of PV's variation (``Fit.accepted``).  Where the first fit is far
    off, its residual is mostly its own error and the reading is not accepted: a load's cycle is read only when the
    valve nearly explains the record already."""
    fit, seeds = first, list(extra)
    for round_ in range(SINUSOID_ROUNDS):  # the first round searches the whole grid again, the others around it
        residual, _ = _best_start_residual(op, pv, *fit.best, ts_s, gain_per_s)
        wave = sinusoid(residual, peak_frequency(residual))
        seeds = [*seeds, fit.best] if round_ == 0 else [fit.best]
        fit = fit_one(op, pv - wave, ts_s, gain_per_s, seeds, coarse=round_ == 0)
    residual, slips = _best_start_residual(op, pv, *fit.best, ts_s, gain_per_s)
    omega, left, unexplained, left_share = _cycle_out(residual, pv)
    fd_se = max(fit.fd_se_pct, SINUSOID_MIN_FD_SE_PCT * few_slips_widening(slips))
    return Fit(fit.fs_pct, fit.fd_pct, fit.fs_se_pct, fd_se, fit.variance_ratio, peak_share(left), slips,
               omega / ts_s, unexplained, fit.best, left_share=left_share)  # fmt: skip


def _cycle_out(residual: np.ndarray, pv: np.ndarray) -> tuple[float, np.ndarray, float, float]:
    """The residual's largest sinusoid taken out: its frequency (rad a sample), what is left (about its mean), that
    left's RMS over PV's standard deviation, and its variance over the residual's."""
    omega = peak_frequency(residual)
    left = residual - sinusoid(residual, omega)
    left = left - left.mean()
    unexplained = float(np.sqrt(np.mean(left**2)) / max(float(np.std(pv)), 1e-12))
    return omega, left, unexplained, float(np.var(left) / max(float(np.var(residual)), 1e-300))


def explains(op, pv, fs_pct: float, fd_pct: float, ts_s: float = 1.0, gain_per_s: float = LEVEL_GAIN_PER_S) -> bool:
    """Whether the valve at this reading (another reader's: the slips') explains the record as ``Fit.accepted`` asks
    of a fit, with or without a load's cycle taken out: where it does, a fit has nothing to add."""
    op, pv = np.asarray(op, float), np.asarray(pv, float)
    residual, slips = _best_start_residual(op, pv, fs_pct, fd_pct, ts_s, gain_per_s)
    sd = second_difference_sd(pv)

    def ratio(x: np.ndarray) -> float:  # its variance over the noise's
        return float(np.mean(x**2) / sd**2) if sd > 0 else np.inf

    plain = Fit(fs_pct, fd_pct, np.nan, np.nan, ratio(residual), peak_share(residual), slips)
    if plain.accepted:
        return True
    omega, left, unexplained, left_share = _cycle_out(residual, pv)
    cycle = Fit(fs_pct, fd_pct, np.nan, np.nan, ratio(left), peak_share(left), slips, omega / ts_s, unexplained,
                left_share=left_share)  # fmt: skip
    return cycle.accepted


def read(op: np.ndarray, pv: np.ndarray, ts_s: float = 1.0, gain_per_s: float = LEVEL_GAIN_PER_S,
         extra: np.ndarray | None = None) -> FittedReading:  # fmt: skip
    """The fitted reading of each window [W, N] of a level loop (``fit_window``); ``extra`` [W, K, 2]: readings to
    search around."""
    op, pv = np.atleast_2d(op), np.atleast_2d(pv)
    fits = [fit_window(op[w], pv[w], ts_s, gain_per_s, () if extra is None else [tuple(e) for e in extra[w]])
            for w in range(op.shape[0])]  # fmt: skip

    def col(name, dtype=float):
        return np.array([getattr(f, name) for f in fits], dtype=dtype)

    return FittedReading(
        col("fs_pct"), col("fd_pct"), col("fs_se_pct"), col("fd_se_pct"), col("variance_ratio"),
        col("peak_share"), col("accepted", bool), col("slips", int), col("sinusoid_rad_s"),
    )  # fmt: skip


def warm_up() -> None:
    """Compile (or load from its cache) the kernel before the first report that fits a valve."""
    op = np.sin(np.arange(32.0) / 5)
    grid = np.array([[10.0, 5.0]])
    _rss(op, op, grid, COARSE_SEGMENT, 1.0, LEVEL_GAIN_PER_S)
