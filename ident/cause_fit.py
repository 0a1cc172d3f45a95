"""One cause of the catalogue fitted on top of the current model, its parameter searched
(``ident.diagnose`` adds causes greedily with these): the grid, the fitter that shares a
record's work, a cheap screen then full fits of the best grid points, a refinement between
them, and the spread of the valve's numbers over the fits the criterion cannot tell apart."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from stiction.ident.fit import criterion, fit_valve, local_minima
from stiction.ident.friction import Friction, effective_samples, load_amplitude_pct
from stiction.ident.models import APPLY, NO_SPREAD, Model
from stiction.ident.process import Dynamics
from stiction.ident.record import Record, process_sign
from stiction.ident.stem import StemReader
from stiction.ident.valve_model import Hypothesis, ValveFit
from stiction.sim.valve import PCT_OF_500LBF_PER_PCT_OF_SPAN, band_and_jump_pct

LONGEST_LAG_SHARE = 1 / 3
"""The longest process lag tried, as a share of the record's span: a longer one changes PV over the
record no more than the noise does, and reads as integrating (``longest_lag_s``)."""


def longest_lag_s(record: Record) -> float:
    """The longest self-regulating lag this record can tell from an integrating process, s."""
    return record.n * record.ts_s * LONGEST_LAG_SHARE


TOLD_LAG_SHARE = 1 / 6
"""The longest process lag the record surely tells from integrating, as a share of its span.  Past it the
fit (whose grid reaches ``LONGEST_LAG_SHARE``) finds some lags and misses others: on 1,000 s records of
``stiction bench diagnose --draws wide --causes process_type`` at seeds 4242, 5151 and 6161, 8 of 8 lags of
14-190 s were found and 4 of 7 of 190-305 s missed.  Where a process reads as integrating the report says
from which lag on that reading may be a self-regulating process instead (``told_lag_s``)."""


def told_lag_s(record: Record) -> float:
    """The longest self-regulating lag this record surely tells from an integrating process, s."""
    return record.n * record.ts_s * TOLD_LAG_SHARE


def _grid(cause: str, record: Record, current: Model) -> np.ndarray:
    ts = record.ts_s
    if cause == "dead_time":  # fine: a fractional delay splits every slip's flow between two samples
        return ts * np.arange(0.1, 12.01, 0.1)
    if cause in ("sensor_lag", "actuator_lag"):
        return ts * np.geomspace(0.3, 20, 18)
    if cause in ("process_type", "process_gain+process_type"):
        return np.geomspace(0.05 * ts, longest_lag_s(record), 18)
    if cause == "process_gain":
        return np.array([1.0])
    if cause == "external_oscillation":
        scan = osc_scan_periods(record)
        peaks = load_periods(record, current.fit)
        return np.unique(np.concatenate([scan, peaks[peaks >= 10 * ts]]))
    raise ValueError(cause)


def osc_scan_periods(record: Record) -> np.ndarray:
    """Periods [s] an external oscillation is scanned over: from ten samples to 40 % of the record."""
    return np.geomspace(10 * record.ts_s, record.n * record.ts_s / 2.5, 40)


def _residual_spectra(record: Record, vf: ValveFit) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The residual's power spectrum (Hann window), the same read as PV levels (the residual is of PV's steps), and
    their frequencies [Hz]; both zero below three cycles in the record."""
    resid = record.target - vf.fit.prediction
    n = resid.size
    power = np.abs(np.fft.rfft(resid * np.hanning(n))) ** 2
    freq = np.fft.rfftfreq(n, record.ts_s)
    lo = max(int(np.searchsorted(freq, 3.0 / (n * record.ts_s))), 1)  # at least three cycles in the record
    power[:lo] = 0
    level = power / np.maximum(np.abs(1 - np.exp(-2j * np.pi * freq * record.ts_s)) ** 2, 1e-12)
    return power, level, freq


def _peaks(spectrum: np.ndarray, count: int) -> np.ndarray:
    """Bins of the ``count`` strongest local maxima of ``spectrum``."""
    peaks = np.flatnonzero((spectrum[1:-1] > spectrum[:-2]) & (spectrum[1:-1] >= spectrum[2:])) + 1
    return peaks[np.argsort(spectrum[peaks])[::-1][:count]]


def residual_periods(record: Record, vf: ValveFit, count: int = 4) -> np.ndarray:
    """Periods [s] of the strongest peaks of the residual's spectrum (as PV levels), longest first."""
    _, level, freq = _residual_spectra(record, vf)
    peaks = _peaks(level, count)
    return np.sort(1.0 / freq[peaks])[::-1] if peaks.size else np.zeros(0)


def load_periods(record: Record, vf: ValveFit, count: int = 4) -> np.ndarray:
    """Periods [s] an external load is fitted at beside the scan (``osc_scan_periods``): the ``count`` strongest
    peaks of the residual read as PV levels (a slow load) and as it is (a fast one, which the levels' weighting
    buries under slow wander), each placed between its bins by a parabola through the log power, longest first.

    A sine fitted over the whole record must hold its phase there: a period off by its own share of the record (2 %
    for 20 cycles) fits nothing.  The scan's 10 % steps and the spectrum's bins (up to half a bin off: 1.3 % at 19 s
    of a 1,000 s record) both miss a fast load; the parabola through a Hann window's peak lands within a few
    hundredths of a bin.  Behind a load of 19.16 s and 3 % (seed 7272 of the wide draws) the four strongest level
    peaks were 23.5-329 s, the best fit there 2,900 behind one at the load's own period, and the diagnosis named a
    dead time, a process gain and a load of a sixth of the amplitude; the residual's own spectrum put its peak at
    19.35 s, the parabola at 19.17 s."""
    power, level, freq = _residual_spectra(record, vf)
    out = []
    for spectrum in (level, power):
        for k in _peaks(spectrum, count):
            a, b, c = np.log(np.maximum(spectrum[k - 1 : k + 2], 1e-300))
            curve = a - 2 * b + c
            beside = min(spectrum[k - 1], spectrum[k + 1]) > 0  # a neighbour below three cycles reads nothing
            shift = float(np.clip(0.5 * (a - c) / curve, -0.5, 0.5)) if curve < 0 and beside else 0.0
            out.append(1.0 / ((k + shift) * freq[1]))
    return np.unique(np.array(out))[::-1]


def _between(grid: np.ndarray, best: int) -> np.ndarray:
    """Two points either side of ``grid[best]``, a third of the way to its neighbours."""
    lo = grid[best - 1] if best > 0 else grid[best] * 0.6
    hi = grid[best + 1] if best + 1 < grid.size else grid[best] * 1.5
    v = grid[best]
    return np.array([v - (v - lo) / 3, v + (hi - v) / 3])


class Fitter:
    """Fits of one record, with the stem paths read under each process hypothesis kept for reuse.

    ``threads`` above 1: fits that do not depend on each other (a screen's grid, a step's full fits) run on that
    many threads.  The compiled kernels and numpy's large operations release the interpreter's lock, and each fit
    is what it would be alone, so the diagnosis is the same whatever the count."""

    def __init__(self, record: Record, threads: int = 1):
        self.record = record
        self.reader = StemReader(record.pv_pct, record.ts_s)
        self.sign = process_sign(record.op_pct, record.pv_pct)
        self.threads = max(1, int(threads))
        self._pool = None

    def _map(self, fn, items: list) -> list:
        """``[fn(x) for x in items]``, on ``threads`` threads where there are several and more than one item."""
        if self.threads == 1 or len(items) < 2:
            return [fn(x) for x in items]
        if self._pool is None:  # one pool for the fitter's life: a pool a call cost a short record more than it won
            from concurrent.futures import ThreadPoolExecutor

            self._pool = ThreadPoolExecutor(self.threads, thread_name_prefix="stiction-fit")
        return list(self._pool.map(fn, items))

    def close(self) -> None:
        """Stops the fitter's threads (if it started any)."""
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def __enter__(self) -> Fitter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _criterion(self, vf: ValveFit) -> float:
        """Schwarz's criterion; a process gain of the sign the controller rules out fits the controller
        backwards (PV read from OP through the PI law), not the plant: no such model."""
        if vf.hypothesis.gain_free and not vf.gain_ratio * self.sign > 0:
            return float("inf")
        return float(criterion(vf.rss, vf.n_params, self.record.n_fit))

    def paths(self, keys: list[tuple[Dynamics, float | None]]):
        """Stem paths under (dynamics, external oscillation period) hypotheses."""
        return self.reader.paths(keys)

    def fast(self, hyps: list[Hypothesis], own_paths: bool = True) -> list[tuple[ValveFit, float]]:
        """First-pass fits (every slip as read): (fit, criterion) each.

        ``own_paths=False`` reads the slips without the external oscillation (a quick scan of periods).
        """
        keys = [(h.dynamics, h.osc_period_s if own_paths else None) for h in hyps]

        def one(item):
            vf = fit_valve(self.record, *item, nominal_gain=self.sign, search="quick")
            return vf, self._criterion(vf)

        return self._map(one, list(zip(hyps, self.paths(keys), strict=True)))

    def with_slips(self, hyp: Hypothesis, slips) -> ValveFit | None:
        """``hyp`` fitted with given slips (no search)."""
        from stiction.ident.fit import refit

        return refit(self.record, hyp, slips, self.sign)

    def full(self, hyp: Hypothesis, start: ValveFit | None = None) -> tuple[ValveFit, float]:
        """The full fit; ``start``, a fitted valve (the current model's), is searched from as well."""
        valve = None if start is None else (start.band_pct, start.stop_pct, start.level0_pct)
        path = self.paths([(hyp.dynamics, hyp.osc_period_s)])[0]
        vf = fit_valve(self.record, hyp, path, nominal_gain=self.sign, search="full", start=valve)
        return vf, self._criterion(vf)

    def fulls(self, hyps: list[Hypothesis], start: ValveFit | None = None) -> list[tuple[ValveFit, float]]:
        """``full`` of each hypothesis, from the same ``start``."""
        return self._map(lambda h: self.full(h, start), hyps)


FULL_FITS_PER_CAUSE = 3
EVERY_SAMPLE = ("dead_time",)
"""Causes whose best screened point in every whole sample of their grid is fitted in full as well as the screen's
lowest minima.  A dead time's first-pass fit reads the slips a sample or two off the delayed stem's
(``ident.diagnose.SCREEN_BLIND``), and its ranking of the delays is no guide beyond a sample: behind a dead time of
4.47 s (seed 9001 of the wide draws, ``tests/ident/test_diagnose.py``) the screen put 4.4 s sixth among its
minima, 171 behind 1.4 s, and the full fits put it 101 ahead.  Up to 12 more full fits a forward step."""


def _whole_samples(values, ts_s: float) -> np.ndarray:
    """The whole samples each value (s) lies in: what ``EVERY_SAMPLE`` and ``RUNNER_UP_SCAN`` group delays by."""
    return np.floor(np.asarray(values, float) / ts_s + 1e-9).astype(int)


ABOVE_THE_SCREEN = {"sensor_lag": 3}
"""Grid points above the screen's best also fitted in full, by cause.  A first-pass fit reads every slip through the
sensor lag's inverse filter, which amplifies PV's noise the more the longer the lag: the spurious slips grow with the
lag and the screen's best lies below the truth.  Behind the sensor lags of the wide draws on the independent
simulator (seed 3737; 2.46, 4.39 and 6.89 s, read 1.48, 3.27 and 4.82) the screen's best lay one to four grid steps
(a factor of 1.28 each) below the truth, where the full fit beat the read by 90-120.  Three steps chosen there
(the lag read within its range 4 -> 7 of 8, fs/fd 2.49 -> 1.40 pp); judged on seeds 8181 (both simulators) and
9292: fs/fd 4.27 -> 2.34, 3.55 -> 2.58 and 2.02 -> 1.38 pp.  Up to three more full fits a forward step."""
RUNNER_UP_SCAN = {"dead_time": (-0.2, -0.1, 0.1, 0.2)}
"""Steps (in samples) about the best full fit of the runner-up whole sample, each fitted in full, by cause.  Within a
sample a dead time's full criterion is as jagged as its screen (behind the dead time of 2.6 s of
``tests/ident/test_diagnose_independent.py``: -4079 at 2.4 s, -4550 at 2.5, -4639 at 2.65, -4410 at 2.8), so the
sample's point ``EVERY_SAMPLE`` fitted may stand 200 behind its best and lose to another sample; there the fit read
0.56 s on one model of the machines (AMD EPYC family 25 model 17) and 2.6 s on another.  Four more full fits a
forward step."""


def runner_up_scanned(
    fitter: Fitter, cause: str, current: Model, fits: list[tuple[float, ValveFit, float]]
) -> list[tuple[float, ValveFit, float]]:
    """``fits`` ((value, fit, criterion) of ``cause``'s full fits) and, for ``RUNNER_UP_SCAN``'s causes, the full fits
    about the best value of the second-best whole sample."""
    steps = RUNNER_UP_SCAN.get(cause)
    if not steps:
        return fits
    ts = fitter.record.ts_s
    best: dict[int, tuple[float, float]] = {}
    for k, (v, _, ic) in zip(_whole_samples([v for v, _, _ in fits], ts), fits, strict=True):
        if k not in best or ic < best[k][1]:
            best[k] = (v, ic)
    if len(best) < 2:
        return fits
    at = sorted(best.values(), key=lambda b: b[1])[1][0]
    done = {v for v, _, _ in fits}
    values = [v for s in steps if (v := at + s * ts) > 0 and v not in done]
    fitted = fitter.fulls([APPLY[cause](current.hypothesis, v) for v in values], current.fit)
    return fits + [(v, *f) for v, f in zip(values, fitted, strict=True)]


CAUSES_FITTED_IN_FULL = 2
MAX_FULL_CAUSES = 4


@dataclass(frozen=True)
class Screened:
    cause: str
    grid: np.ndarray
    criteria: np.ndarray
    fits: list[ValveFit]


OSC_RESCREENED = 3


def screen(fitter: Fitter, cause: str, current: Model) -> Screened | None:
    """The cause's parameter on its grid, with first-pass fits (every slip as read).

    Periods of an external oscillation are scanned with the slips read as if there were none
    (cheap: one segmentation), and the best few again with the load taken out before the slips
    are read: the sine otherwise reads as extra slips and spoils every first-pass fit.
    """
    grid = _grid(cause, fitter.record, current)
    if grid.size == 0:
        return None
    hyps = [APPLY[cause](current.hypothesis, v) for v in grid]
    scored = fitter.fast(hyps, own_paths=cause != "external_oscillation")
    crit = np.array([ic for _, ic in scored])
    fits = [vf for vf, _ in scored]
    if cause == "external_oscillation":
        for i in np.argsort(crit)[:OSC_RESCREENED]:
            ((fits[i], crit[i]),) = fitter.fast([hyps[i]], own_paths=True)
    return Screened(cause, grid, crit, fits)


def full_values(fitter: Fitter, sc: Screened) -> list[float]:
    """The parameter values a cause is fitted in full at (``best_of_full``): the screening curve's best local minima,
    and points beside the best (and, for ``EVERY_SAMPLE``'s causes, the best of every whole sample; for
    ``ABOVE_THE_SCREEN``'s, the grid's next points above the best), each once."""
    minima = local_minima(sc.criteria, FULL_FITS_PER_CAUSE)
    values = [float(sc.grid[i]) for i in minima]
    if sc.cause in EVERY_SAMPLE:
        whole = _whole_samples(sc.grid, fitter.record.ts_s)
        held = {int(whole[i]) for i in minima}
        for k in np.unique(whole):
            at = np.flatnonzero(whole == k)
            if int(k) not in held:
                values.append(float(sc.grid[at[np.argmin(sc.criteria[at])]]))
    above = ABOVE_THE_SCREEN.get(sc.cause, 0)
    values += [float(v) for v in sc.grid[minima[0] + 1 : minima[0] + 1 + above]]
    if sc.cause != "process_gain" and sc.grid.size > 1:
        values += [float(v) for v in _between(sc.grid, minima[0])]
    if "process_type" in sc.cause:  # a lag as long as the grid's longest is no lag the record can tell
        values = [v for v in values if v < 0.999 * sc.grid.max()] or [float(sc.grid[-2])]
    return list(dict.fromkeys(values))


def best_of_full(fitter: Fitter, sc: Screened, current: Model, fits: list[tuple[float, ValveFit, float]]) -> Model:
    """The cause at the best of its full fits ``fits`` ((value, fit, criterion) at each of its ``full_values``), with
    the valve's spread over them."""
    value, vf, ic = min(fits, key=lambda f: f[2])
    hyp = APPLY[sc.cause](current.hypothesis, value)
    amplitude = load_amplitude_pct(fitter.record, vf) if hyp.osc_period_s else current.load_amplitude_pct
    own = spread(fitter.record, [(f, c) for _, f, c in fits])
    return Model(
        hyp,
        vf,
        ic,
        (*current.causes, *names(sc.cause)),
        current.quantum_pct,
        None,
        amplitude,
        combined(current.spread, own),
        tuple(sorted(fits, key=lambda f: f[0])),
    )


REFINE_STEPS = 2
LOCAL_SCAN = {"sensor_lag": (-0.12, -0.06, 0.06, 0.12), "actuator_lag": (-0.12, -0.06, 0.06, 0.12)}
"""Steps (relative) about the best lag, each fitted in full after the parabola.  Over a lag the criterion is
jagged, not a parabola: each lag reads the slips through its own inverse filter, and a few per cent move a
slip by a sample; behind a sensor lag of 3.7 s (seed 7070 of the wide draws) the criterion was -3683 at the
refined 3.25 s (fs read 93 %, the truth 61), -3767 at 3.66 and -3810 at 4.10 (fs 61.5).  The steps are within
the grid's own (28 %), chosen before measuring; on the 8 sensor lags of that seed fs/fd 7.9 -> 3.2 pp."""


JITTER = (-0.005, 0.005)
"""Steps (relative) about the best lag after the local scan, each fitted in full.  The slips a full fit reads come
through the lag's inverse filter, and a change of a tenth of a per cent in the lag can read another set: behind the
sensor lag of ``LOCAL_SCAN``'s loop, fits at 3.60-3.70 s lay at -3711 or at -3766 by the slips read, alternating
(3.6435 s: -3711 and fs 81 %, 3.645 s: -3766 and fs 61, the truth), and which point the scan met depended on the
machine's rounding (AMD EPYC family 25 against family 26).  Half a per cent either way is below what any record
tells of a lag and costs two full fits."""


def _tried(
    fitter: Fitter, best: Model, cause: str, current: Model, value: float, points: list,
    fitted: tuple[ValveFit, float] | None = None,
) -> Model:  # fmt: skip
    """``cause`` at ``value`` fitted in full (``fitted``: that fit, where the caller made it) and added to
    ``points``; the better of it and ``best``."""
    hyp = APPLY[cause](current.hypothesis, value)
    vf, ic = fitter.full(hyp, current.fit) if fitted is None else fitted
    points.append((value, vf, ic))
    if ic >= best.criterion:
        return best
    amplitude = load_amplitude_pct(fitter.record, vf) if hyp.osc_period_s else best.load_amplitude_pct
    return replace(best, hypothesis=hyp, fit=vf, criterion=ic, load_amplitude_pct=amplitude)


def refined(fitter: Fitter, model: Model, cause: str, current: Model) -> Model:
    """The winning cause's parameter between the grid's points: the vertex of a parabola through
    the best fit and its neighbours (in log of the parameter), fitted in full while it improves.
    A grid a third of a step apart still misreads a lag by 10-15 %, and the band with it."""
    if cause == "process_gain" or len(model.profile) < 3:
        return model
    points = list(model.profile)
    best = model
    for _ in range(REFINE_STEPS):
        points.sort(key=lambda p: p[0])
        k = int(np.argmin([c for _, _, c in points]))
        if k == 0 or k == len(points) - 1:
            break
        (x0, c0), (x1, c1), (x2, c2) = ((np.log(v), c) for v, _, c in points[k - 1 : k + 2])
        denom = (x1 - x0) * (c1 - c2) - (x1 - x2) * (c1 - c0)
        if not (np.isfinite(denom) and denom != 0):  # a neighbour with no model (inf) bounds the search
            break
        x = x1 - 0.5 * ((x1 - x0) ** 2 * (c1 - c2) - (x1 - x2) ** 2 * (c1 - c0)) / denom
        if not (x0 < x < x2) or min(abs(x - x0), abs(x - x1), abs(x - x2)) < 0.01:
            break
        best = _tried(fitter, best, cause, current, float(np.exp(x)), points)
    for steps in (LOCAL_SCAN[cause], JITTER) if cause in LOCAL_SCAN else ():
        at = min(points, key=lambda p: p[2])[0]  # each scan about the best lag the one before it left
        values = [at * (1 + step) for step in steps]
        fitted = fitter.fulls([APPLY[cause](current.hypothesis, v) for v in values], current.fit)
        for value, fit in zip(values, fitted, strict=True):  # in the scan's order, as one by one
            best = _tried(fitter, best, cause, current, value, points, fit)
    own = spread(fitter.record, [(f, c) for _, f, c in points])
    return replace(best, spread=combined(current.spread, own), profile=tuple(sorted(points, key=lambda p: p[0])))


def _valve_of(vf: ValveFit) -> tuple[float, float, float, float]:
    """(static band, stop, S, J) of a fit, % of span (nan where not read)."""
    band = vf.band_pct
    stop = band - vf.jump_pct if np.isfinite(vf.jump_pct) else vf.stop_pct
    s, j = band_and_jump_pct(band * PCT_OF_500LBF_PER_PCT_OF_SPAN, stop * PCT_OF_500LBF_PER_PCT_OF_SPAN)
    return band, stop, float(s), float(j)


def spread(record: Record, fits: list[tuple[ValveFit, float]]) -> tuple[float, ...]:
    """Weighted spread of ``SPREAD_FIELDS`` over rival fits of one record.

    Each fit weighs exp(-delta/2), delta its criterion above the best counted over the residual's
    effective samples (neighbouring residuals are not independent evidence): fits the data cannot
    tell from the best count fully, fits far behind not at all.  This is the friction's uncertainty
    from what the selection could not pin down (a dead time against an actuator lag, a lag of 3 s
    against one of 5 s), which the chosen fit's covariance does not see.
    """
    values = np.array([_valve_of(vf) for vf, _ in fits], dtype=float)
    crit = np.array([c for _, c in fits], dtype=float)
    ok = np.all(np.isfinite(values), axis=1) & np.isfinite(crit)
    if ok.sum() < 2:
        return NO_SPREAD
    values, crit = values[ok], crit[ok]
    best = int(np.argmin(crit))
    best_fit = [vf for (vf, _), k in zip(fits, ok, strict=True) if k][best]
    n_eff = effective_samples(record.target - best_fit.fit.prediction)
    w = np.exp(-0.5 * (crit - crit[best]) * n_eff / record.n_fit)
    mean = w @ values / w.sum()
    sd = np.sqrt(w @ (values - mean) ** 2 / w.sum())
    return tuple(float(v) for v in sd)


def combined(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, ...]:
    return tuple(float(np.hypot(x, y)) for x, y in zip(a, b, strict=True))


def widened(f: Friction, spread: tuple[float, ...]) -> Friction:
    """``f`` with the model uncertainty added to its standard errors (in quadrature)."""
    if not any(spread):
        return f
    band, stop, s, j = spread
    k = PCT_OF_500LBF_PER_PCT_OF_SPAN
    return replace(
        f,
        s_se_pct=float(np.hypot(f.s_se_pct, s)),
        j_se_pct=float(np.hypot(f.j_se_pct, j)),
        fs_se_pct=float(np.hypot(f.fs_se_pct, band * k)),
        fd_se_pct=float(np.hypot(f.fd_se_pct, stop * k)),
    )


def names(move: str) -> tuple[str, ...]:
    """The catalogue causes a move of the search names (one, or two searched together)."""
    return tuple(move.split("+"))


def baseline(fitter: Fitter, current: Model, tried: Model) -> Model:
    """The current model at its best: refitted with the slips the tried model found, where that is better.

    A cause must not get the credit for a better valve fit that its search happened upon.
    """
    vf = fitter.with_slips(current.hypothesis, tried.fit.slips)
    if vf is None:
        return current
    ic = criterion(vf.rss, vf.n_params, fitter.record.n_fit)
    return replace(current, fit=vf, criterion=ic) if ic < current.criterion else current


SEARCHED = (
    "process_gain",
    "process_type",
    "process_gain+process_type",
    "dead_time",
    "sensor_lag",
    "actuator_lag",
    "external_oscillation",
)


def quantised(record: Record, current: Model, q: float) -> Model | None:
    """The record's lattice as a cause: the part of the model's error that the rounding itself adds.

    Stored values on a lattice of step q carry a rounding error of variance q^2/12 that no model of
    the loop can remove.  The lattice is read from the values (``ident.lattice``): it is a fact of the
    record however fine, and named so (a quantum below the noise explains little of the error, and
    the candidate says how much); the extended error is what remains once it is taken out.  Its
    criterion treats that variance as known noise.  None where the model has no error to explain.
    """
    error = current.error_pct(record)
    if error <= 0:
        return None
    left = max(error**2 - q * q / 12.0, 1e-12 * error**2)
    delta = record.n_fit * np.log(left / error**2) + np.log(record.n_fit)
    return Model(
        current.hypothesis,
        current.fit,
        current.criterion + float(delta),
        (*current.causes, "quantization"),
        q,
        current.rss * left / error**2,
        current.load_amplitude_pct,
        current.spread,
    )
