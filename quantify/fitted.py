"""The fitted reading: the physical valve fitted to the whole record of a level loop (output error).

The physical reading (``quantify.physical``) reads the stem from PV's steps, ``15 s * dPV``: a measurement
noise on PV is differenced there, and beyond a few tenths of a percent it hides the slips (the readings'
errors exceed their trust and the learned ensemble speaks, 2.1 pp off on average on the thesis's noisy random
loops).  Here the noise is not differenced.  OP is recorded as the controller wrote it, and for a known level
loop (``PV' = MV / 15 s``, spec/thesis-loop.md) the stem the valve makes of it is a deterministic function of
the recorded OP and the friction: a valve driven by a record of OP is not the chaotic closed loop, it is an
open-loop recursion.  So each candidate (fs, fd) gives a level, the recorded OP's stem integrated, and the
candidate whose level leaves PV the smallest residual is the reading.

- The residual is jagged in fs and fd: a candidate 0.1 % of 500 lbf off moves one breakaway by a sample, and the
  level, an integral, keeps the offset.  The search runs coarse to fine on residuals with a free offset in
  every stretch of ``COARSE_SEGMENT`` and ``MEDIUM_SEGMENT`` samples (a late offset costs only its stretch) and
  ends on the whole window (``POLISH_SEGMENT``), from the best few candidates of each stage.
- The stem's start is not known: each candidate is tried from ``START_SHARES`` places within its band around
  the first OP, the best kept (after its first slips the stem forgets where it started).
- **The model must explain the record.**  The reading is accepted only where what it leaves is the measurement's
  white noise: its variance within ``MAX_VARIANCE_RATIO`` of the noise's (read from PV's second differences,
  robustly: a slip is one sample in many), and no periodic part in it (``MAX_PEAK_SHARE``: Fisher's test of a
  periodogram's largest ordinate).  A load on the process input, a sine on the output, another valve or
  process: the residual says so, and the reading is withheld.
- Its standard errors are those the medium stage's profile gives (the candidates within the 95 % band of
  the residual's chi-square), never under ``MIN_SE_PCT``: the profile of a jagged residual is narrower than
  the reading's error, and on the design seeds the floor is what holds the truth.

Constants chosen on random loops of seeds 3131-3133 (docs/benchmarks.md, "The fitted reading"); ``stiction
bench accuracy``'s sets judged after.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.quantify.fitted_kernel import segment_rss
from stiction.sim.process import LOOPS
from stiction.sim.valve import Friction, pct_to_lbf

LEVEL_GAIN_PER_S = LOOPS["level"].gain
START_SHARES = np.linspace(-0.9, 0.9, 7)
"""Where the stem may start, in shares of its band (``fs / 12 lbf per %``) either side of the first OP."""
COARSE_STEP_PCT = 1.0
COARSE_SEGMENT = 25
MEDIUM_STEP_PCT = 0.1
MEDIUM_HALF_PCT = 2.0
MEDIUM_SEGMENT = 100
POLISH_STEP_PCT = 0.02
POLISH_HALF_PCT = 0.3
SEEDS = 5
"""Local minima of the coarse stage taken on (beside the readings given as ``extra``)."""
KEEP = 4
"""Candidates of the medium stage polished."""
MAX_FS_PCT = 100.0
MAX_VARIANCE_RATIO = 2.5
MAX_PEAK_SHARE = 0.05
MIN_SE_PCT = (0.4, 0.05)
"""The least standard errors (fs, fd): on the 53 accepted readings of the design seeds (3131-3133) the errors' 95th
percentiles were 0.80 and 0.066 (medians 0.11 and 0.01), where the profile gave 0.1-0.4 and 0.1-0.13: two of
these hold about 95 % of the truth."""


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
    """The model explains the record (``MAX_VARIANCE_RATIO``, ``MAX_PEAK_SHARE``): the reading may speak."""


def stem_path(op: np.ndarray, fs_pct: float, fd_pct: float, mv0_pct: float, ts_s: float = 1.0,
              gain_per_s: float = LEVEL_GAIN_PER_S) -> np.ndarray:  # fmt: skip
    """[N] the level (from 0) the recorded ``op`` makes through a valve of friction ``fs_pct``, ``fd_pct`` whose stem
    starts stuck at ``mv0_pct``: the definition ``fitted_kernel.segment_rss`` is held to, one sample at a time."""
    fr = Friction.physical(pct_to_lbf(np.array([fs_pct])), pct_to_lbf(np.array([fd_pct])))
    level, mv, out = 0.0, float(mv0_pct), np.empty(len(op))
    for k, drive in enumerate(np.asarray(op, float)):
        out[k] = level
        force = fr.lbf_per_pct * (drive - mv)
        flow = mv
        if abs(force) > fr.fs_lbf[0]:
            jump = (force - np.sign(force) * fr.stop_lbf[0]) / fr.lbf_per_pct
            mv += jump
            flow = mv - jump * fr.slip_s / ts_s
        level += gain_per_s * ts_s * flow
    return out


def _rss(op, pv, grid, segment, ts_s, gain_per_s) -> np.ndarray:
    """[C] each candidate's residual (``segment_rss``), the best of its starts (``START_SHARES``)."""
    fr = Friction.physical(pct_to_lbf(grid[:, 0]), pct_to_lbf(grid[:, 1]))
    band = fr.fs_lbf / fr.lbf_per_pct
    best = np.full(len(grid), np.inf)
    for share in START_SHARES:
        rss = segment_rss(op, pv, fr.fs_lbf, fr.stop_lbf, op[0] - share * band, fr.slip_s / ts_s,
                          gain_per_s * ts_s, fr.lbf_per_pct, segment)  # fmt: skip
        best = np.minimum(best, rss)
    return best


def _around(centre, half: float, step: float) -> np.ndarray:
    """The candidates (fs, fd) of a square grid around ``centre`` that a valve can have (0 <= fd < fs <= max)."""
    axis = np.arange(-half, half + step / 2, step)
    fs, fd = np.meshgrid(centre[0] + axis, centre[1] + axis, indexing="ij")
    grid = np.column_stack([fs.ravel(), fd.ravel()])
    keep = (grid[:, 1] >= 0) & (grid[:, 1] < grid[:, 0]) & (grid[:, 0] <= MAX_FS_PCT)
    return grid[keep]


def _coarse_grid() -> np.ndarray:
    fs = np.arange(COARSE_STEP_PCT, MAX_FS_PCT + COARSE_STEP_PCT / 2, COARSE_STEP_PCT)
    return np.array([(a, b) for a in fs for b in np.arange(0.0, a, COARSE_STEP_PCT)])


def _minima(grid: np.ndarray, rss: np.ndarray, count: int, apart: float) -> list[np.ndarray]:
    """The ``count`` best candidates at least ``apart`` from each other (in fs or fd)."""
    out: list[np.ndarray] = []
    for i in np.argsort(rss):
        if all(np.max(np.abs(grid[i] - c)) > apart for c in out):
            out.append(grid[i])
        if len(out) == count:
            break
    return out


def noise_sd(pv: np.ndarray) -> float:
    """The measurement noise's standard deviation from PV's second differences (a white noise's variance six
    times), by their median absolute deviation: a slip is one sample in many and does not move it."""
    d2 = np.diff(np.asarray(pv, float), 2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


def peak_share(residual: np.ndarray) -> float:
    """The largest ordinate of the residual's periodogram over their sum (Fisher's g): about ``ln(n/2) / (n/2)``
    for white noise (1.2 % at 1,000 samples), most of it for a sine."""
    r = np.asarray(residual, float) - np.mean(residual)
    power = np.abs(np.fft.rfft(r)[1:]) ** 2
    return float(power.max() / power.sum()) if power.sum() > 0 else 0.0


def _best_start_residual(op, pv, fs_pct, fd_pct, ts_s, gain_per_s) -> np.ndarray:
    fr = Friction.physical(pct_to_lbf(np.array([fs_pct])), pct_to_lbf(np.array([fd_pct])))
    band = float(fr.fs_lbf[0]) / fr.lbf_per_pct
    best = None
    for share in START_SHARES:
        r = pv - stem_path(op, fs_pct, fd_pct, op[0] - share * band, ts_s, gain_per_s)
        r = r - r.mean()
        if best is None or r @ r < best @ best:
            best = r
    return best


def fit_one(op, pv, ts_s: float = 1.0, gain_per_s: float = LEVEL_GAIN_PER_S, extra=()) -> tuple:
    """``(fs, fd, fs_se, fd_se, variance_ratio, peak_share)`` of one window; ``extra``: readings (fs, fd) to search
    around beside the coarse stage's minima (the physical reading beyond its trust, the learned one)."""
    op, pv = np.asarray(op, float), np.asarray(pv, float)
    n = op.size
    coarse = _coarse_grid()
    seeds = _minima(coarse, _rss(op, pv, coarse, COARSE_SEGMENT, ts_s, gain_per_s), SEEDS, 3 * COARSE_STEP_PCT)
    seeds += [np.asarray(e, float) for e in extra if np.all(np.isfinite(e)) and 0 <= e[1] < e[0] <= MAX_FS_PCT]
    medium = []
    for centre in seeds:
        grid = _around(centre, MEDIUM_HALF_PCT, MEDIUM_STEP_PCT)
        rss = _rss(op, pv, grid, MEDIUM_SEGMENT, ts_s, gain_per_s)
        medium += [(rss[i], grid[i], grid, rss) for i in np.argsort(rss)[:2]]
    medium.sort(key=lambda m: m[0])
    best = (np.inf, None, None)
    for _, centre, grid, rss in medium[:KEEP]:
        fine = _around(centre, POLISH_HALF_PCT, POLISH_STEP_PCT)
        fine_rss = _rss(op, pv, fine, n, ts_s, gain_per_s)
        i = int(np.argmin(fine_rss))
        if fine_rss[i] < best[0]:
            best = (fine_rss[i], fine[i], (grid, rss))
    rss_min, (fs, fd), (grid, rss) = best
    # the medium stage's profile: the candidates within chi-square's 95 % band of its best
    s2 = rss.min() / (n - n // MEDIUM_SEGMENT - 2)
    inside = grid[rss <= rss.min() + 3.84 * s2]
    se = np.maximum(np.ptp(inside, axis=0) / (2 * 1.96), MIN_SE_PCT)
    sd = noise_sd(pv)
    ratio = rss_min / (n * sd**2) if sd > 0 else np.inf
    peak = peak_share(_best_start_residual(op, pv, fs, fd, ts_s, gain_per_s))
    return float(fs), float(fd), float(se[0]), float(se[1]), float(ratio), peak


def read(op: np.ndarray, pv: np.ndarray, ts_s: float = 1.0, gain_per_s: float = LEVEL_GAIN_PER_S,
         extra: np.ndarray | None = None) -> FittedReading:  # fmt: skip
    """The fitted reading of each window [W, N] of a level loop; ``extra`` [W, K, 2]: readings to search around."""
    op, pv = np.atleast_2d(op), np.atleast_2d(pv)
    rows = []
    for w in range(op.shape[0]):
        seeds = () if extra is None else [tuple(e) for e in np.asarray(extra)[w]]
        rows.append(fit_one(op[w], pv[w], ts_s, gain_per_s, seeds))
    fs, fd, fs_se, fd_se, ratio, peak = (np.array(col, float) for col in zip(*rows, strict=True)) if rows else [
        np.zeros(0)] * 6  # fmt: skip
    accepted = (ratio <= MAX_VARIANCE_RATIO) & (peak <= MAX_PEAK_SHARE)
    return FittedReading(fs, fd, fs_se, fd_se, ratio, peak, accepted)


def warm_up() -> None:
    """Compile (or load from its cache) the kernel before the first report that fits a valve."""
    op = np.sin(np.arange(32.0) / 5)
    grid = np.array([[10.0, 5.0]])
    _rss(op, op, grid, COARSE_SEGMENT, 1.0, LEVEL_GAIN_PER_S)
