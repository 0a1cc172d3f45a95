"""Oscillation detection for any sample time: the regularity of zero crossings.

Thornhill, Huang & Zhang (2003), "Detection of multiple oscillations in control loops",
J. Process Control 13: the intervals between zero crossings of the autocorrelation
function of an oscillating signal are regular; ``r = mean(T) / (3 std(T))`` over the
period estimates ``T`` from successive intervals, and ``r > 1`` is an oscillation.

A slow limit cycle with only two or three cycles in the window (flow loops recorded every
10 s) leaves too few ACF crossings beyond the lags the ACF can still see, so the same
statistic is also taken on the zero crossings of the signal itself (with hysteresis,
after removing its linear trend): the window oscillates if either is regular.

A cycle of steady swing is also read by its periods' median and median absolute deviation
(``kernels.robust_regularity``), the larger r counting: a stick-slip cycle that the noise breaks early now and
then, or that stops for a while, leaves a few outlying periods, which the mean and standard deviation read as
irregularity (the independent simulator's sticky flow loops of seed 777, ``sim.two_parameter``: 8 of 20 clear
stick-slip cycles of 9-16 samples read r 0.4-1.0).  Only where the half cycles' swings are steady
(``STEADY_SWING``): a loop ringing under noise (an aggressive controller) also crosses zero at its own period
most of the time, but with the random swing of narrow-band noise, and read by the median alone it was called
sticky 4-10 % of the time instead of 0-3 % (docs/benchmarks.md).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stiction.detect import kernels

REGULAR = 1.5
"""Thornhill's threshold is r > 1; on 100 windows each of random walks, AR(1) and smoothed white noise
(751 samples) it called 6-20 % of them oscillating, 1.5 calls 5-9 % and still finds 96 % of noisy sines.  With a
steady swing's cycles also read by the median (``STEADY_SWING``), 100 of each, seed 42: 8, 9 and 7 % called, as
before, and 100 of 100 sines of periods 20-200 samples under noise of 0.2-1 of their amplitude."""
MIN_CYCLES = 2.0
"""Fewer cycles than this in the window are not an oscillation one can read."""
HYSTERESIS_STD = 0.3
ACF_PEAK = 0.2
"""The ACF at one period must come back at least this high (biased estimate: a clean slow cycle reaches 1 - P/N)."""
FEW_INTERVALS = 10
FEW_PENALTY = 2.0
"""With fewer half periods than FEW_INTERVALS the signal's crossings must be this much more regular."""
STEADY_SWING = 0.35
"""The half cycles' swings vary less than this (their MAD over their median, ``kernels.swing_spread``) in a cycle
read by the median of its periods.  Set from that reasoning before its benchmark ran: between a limit cycle's
swing under noise and narrow-band noise's, whose envelope (Rayleigh) varies by about half its mean; 0.2, run
beside it, kept less of the gain and none of the cost (docs/benchmarks.md)."""
MIN_ROBUST_CROSSINGS = 6
"""Zero crossings (four periods) from which the signal's periods are also read by their median."""
MAX_LAG_SHARE = 0.75
"""The ACF is read up to this share of the window; beyond it too few products remain."""


@dataclass(frozen=True)
class Oscillation:
    oscillating: bool
    period_s: float | None
    regularity: float
    """Thornhill's r (the larger of the ACF's and the signal's); > 1 regular."""
    cycles: float
    """Cycles of the period in the window."""
    amplitude_pct: float
    """Median over half cycles of the smoothed, detrended signal's 90th-percentile excursion, % of span."""


def detrend(x: np.ndarray) -> np.ndarray:
    """``x`` less its least-squares straight line (closed form)."""
    x = np.asarray(x, float)
    n = x.size
    if n < 2:
        return x - x.mean() if n else x
    t = np.arange(n, dtype=float) - (n - 1) / 2  # centred: slope and mean are independent
    slope = float(t @ (x - x.mean())) / float(t @ t)
    return x - x.mean() - slope * t


@dataclass(frozen=True)
class Detrended:
    """A signal less its least-squares straight line, and that remainder's standard deviation: what
    every test of the window starts from (``detrended_rows`` makes them for a batch at once)."""

    y: np.ndarray
    sd: float


ROUNDING_REL = 1e-9
"""A remainder whose standard deviation is below this share of the signal's size (or of 1) is the
arithmetic's rounding, not a signal: a straight line, as a historian's compression stores a stretch,
left remainders of 1e-15 whose zero crossings read as a perfectly regular oscillation, and the
verdict of such a window changed with an offset added to PV."""


def _rounding_only(sd, x) -> np.ndarray:
    """Whether each remainder's ``sd`` is within the rounding of its signal ``x`` ([N] or [W, N])."""
    size = np.maximum(1.0, np.max(np.abs(x), axis=-1))
    return np.asarray(sd) <= ROUNDING_REL * size


def detrended(x: np.ndarray) -> Detrended:
    y = detrend(x)
    sd = float(np.std(y))
    if y.size and _rounding_only(sd, np.asarray(x, float)):
        return Detrended(np.zeros_like(y), 0.0)
    return Detrended(y, sd)


def detrended_rows(x: np.ndarray) -> list[Detrended]:
    """``detrended`` of each row of ``x`` [W, N], computed for all rows at once."""
    x = np.asarray(x, float)
    n = x.shape[1]
    if n < 2:
        return [detrended(row) for row in x]
    t = np.arange(n, dtype=float) - (n - 1) / 2
    centred = x - x.mean(axis=1, keepdims=True)
    y = centred - ((centred @ t) / float(t @ t))[:, None] * t
    sd = y.std(axis=1)
    flat = _rounding_only(sd, x)
    y[flat], sd[flat] = 0.0, 0.0
    return [Detrended(y[i], float(sd[i])) for i in range(x.shape[0])]


def _crossings(x: np.ndarray, hysteresis: float) -> np.ndarray:
    """Indices where ``x`` passes from below ``-h`` to above ``+h`` or back, at its zero crossing:
    where the state (+1 above h, -1 below -h) changes, walked back to the first sample of the run
    of the new sign before it (compiled: ``detect.kernels``)."""
    return kernels.crossings(np.ascontiguousarray(x, dtype=float), float(hysteresis))


def _regularity(crossings: np.ndarray) -> tuple[float, float]:
    """(r, period in samples) from successive zero crossings (half periods apart): ``r = mean / (3 sd)``
    of the periods, each pair of half periods one period (compiled: ``detect.kernels``; small arrays,
    where numpy's mean and std cost 25 us a call)."""
    r, period = kernels.regularity(np.asarray(crossings, dtype=np.int64))
    return float(r), float(period)


def _peak_near(r: np.ndarray, lag: float) -> float:
    """Highest ACF value within a quarter period of ``lag``."""
    lo, hi = int(lag * 0.75), min(int(lag * 1.25) + 1, r.size)
    return float(r[lo:hi].max()) if hi > lo else 0.0


def autocorrelation(x: np.ndarray, max_lag: int) -> np.ndarray:
    """``r_k = c_k / c_0`` of thesis 4.5 for lags ``0..max_lag`` of each row of ``x``.

    ``c_k = 1/(N-1) sum_{t<=N-k} (y_t - ybar)(y_{t+k} - ybar)`` with the same
    normalisation for ``c_0``; computed with one FFT per row.
    """
    x = np.atleast_2d(np.asarray(x, dtype=float))
    n = x.shape[1]
    centred = x - x.mean(axis=1, keepdims=True)
    size = 1 << int(np.ceil(np.log2(2 * n)))
    spectrum = np.fft.rfft(centred, size, axis=1)
    c = np.fft.irfft(spectrum * np.conj(spectrum), size, axis=1)[:, : max_lag + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        return c / c[:, :1]


def half_cycles(y: np.ndarray, sd: float) -> tuple[np.ndarray, np.ndarray]:
    """``(smoothed y, its zero crossings)``: lightly smoothed so that noise does not cross, with
    hysteresis of ``HYSTERESIS_STD`` standard deviations ``sd``."""
    width = max(1, min(y.size // 50, 5))
    smooth = np.convolve(y, np.ones(width) / width, mode="same") if width > 1 else y
    return smooth, _crossings(smooth, HYSTERESIS_STD * sd)


def max_lag(n: int) -> int:
    """The longest lag of the ACF ``detect`` reads in a window of ``n`` samples."""
    return int(MAX_LAG_SHARE * n)


def detect(
    x: np.ndarray, ts_s: float = 1.0, d: Detrended | None = None, acf: np.ndarray | None = None
) -> Oscillation:
    """Whether one signal (PV or the control error, % of span) oscillates, its period and regularity
    (``d``: the signal's ``detrended``, ``acf``: its ``autocorrelation`` up to ``max_lag``, where the
    caller has them: a batch's ACFs in one transform)."""
    x = np.asarray(x, dtype=float)
    n = x.size
    d = d if d is not None else detrended(x)
    y, sd = d.y, d.sd
    if not sd > 0:
        return Oscillation(False, None, 0.0, 0.0, 0.0)
    r_acf = acf if acf is not None else autocorrelation(y, max_lag(n))[0]  # sd > 0, so c_0 > 0
    zc = _crossings(r_acf, 2.0 / np.sqrt(n))  # the ACF's own estimation noise is about 1/sqrt(n)
    r1, p1 = _regularity(zc)
    if np.isfinite(p1) and _peak_near(r_acf, p1) < ACF_PEAK:
        r1 = 0.0  # regular crossings of an ACF that never comes back: coloured noise, not a cycle
    smooth, sc = half_cycles(y, sd)  # the signal's own crossings
    r2, p2 = _regularity(sc)
    if sc.size - 1 < FEW_INTERVALS:
        r2 /= FEW_PENALTY  # a handful of half periods is regular by chance more often
    r, period = (r1, p1) if r1 >= r2 else (r2, p2)
    if sc.size >= MIN_ROBUST_CROSSINGS:  # a cycle with a few outlying periods, of steady swing
        r3, p3 = kernels.robust_regularity(np.asarray(sc, dtype=np.int64))
        r3 /= FEW_PENALTY if sc.size - 1 < FEW_INTERVALS else 1.0
        if r3 > r and kernels.swing_spread(np.ascontiguousarray(smooth, dtype=float), sc) < STEADY_SWING:
            r, period = float(r3), float(p3)
    if not np.isfinite(period):
        return Oscillation(False, None, float(max(r1, r2)), 0.0, 0.0)
    cycles = n / period
    amplitude = _amplitude(smooth, sc) if sc.size >= 3 else float(np.ptp(smooth)) / 2
    oscillating = bool(r > REGULAR and cycles >= MIN_CYCLES)
    return Oscillation(oscillating, float(period * ts_s), float(r), float(cycles), amplitude)


def _amplitude(y: np.ndarray, crossings: np.ndarray) -> float:
    """The median over half cycles of the 90th percentile of |y| in each: its peak, without the
    noise's extremes (compiled: ``detect.kernels``)."""
    peak = kernels.half_cycle_peaks(np.ascontiguousarray(y, dtype=float), np.asarray(crossings, dtype=np.int64))
    return float(peak) if np.isfinite(peak) else float(np.ptp(y)) / 2
