"""What the canonical simulation gets wrong on a measured loop, why, and what fixing it gains.

The nominal model is the canonical loop of spec/thesis-loop.md driven open loop by the
measured OP: the physical valve (fs, fd free) and the level process ``1/(15 s)``.  Every
cause of the catalogue (``sim.extensions.CATALOGUE``) is fitted on top of the current model
with its parameter searched; Schwarz's criterion (``ident.fit.criterion``) makes each
parameter earn its place, and causes are added greedily while one of them improves it
(forward selection), so a loop with two effects names both, in order.

Two entries cannot be told from the data: a deadband in front of a sticky valve is exactly
a wider band with a larger fd (both grow by half the deadband's width, the jump stays; see
``tests/ident/test_diagnose.py``), so it is reported as not identifiable and read as part
of the friction; and quantisation is a property of the record, read from the lattice its
values sit on, whose extended model is the prediction snapped to that lattice.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from ident import fit, lattice
from ident.fit import Friction, Hypothesis, ValveFit, criterion, fit_valve, friction
from ident.process import Dynamics
from ident.record import Record
from ident.stem import StemReader

MAX_CAUSES = 4
MARGIN = 0.0
"""Criterion improvement a cause must bring beyond its parameter's own price."""


@dataclass(frozen=True)
class Model:
    """One fitted model: its hypothesis, fit, criterion and the causes it stands for."""

    hypothesis: Hypothesis
    fit: ValveFit
    criterion: float
    causes: tuple[str, ...] = ()
    quantum_pct: float | None = None
    rss_override: float | None = None
    load_amplitude_pct: float = float("nan")

    @property
    def rss(self) -> float:
        return self.fit.rss if self.rss_override is None else self.rss_override

    def step_error_pct(self, record: Record) -> float:
        """RMS of the one-sample PV prediction error (what the criterion weighs), % of span."""
        return float(np.sqrt(self.rss / record.n_fit))

    def error_pct(self, record: Record) -> float:
        """RMS difference between measured PV and PV as the model simulates it from OP, % of span.

        The simulation is open loop in the process (its offset and drift fitted): the figure a
        plant engineer sees in the plot.  A quantised record is compared on its own lattice.
        """
        sim = fit.simulated_pv(self.fit, record)
        if self.quantum_pct:
            origin = float(record.pv_pct[np.argmin(np.abs(record.pv_pct))])
            sim = lattice.snap(sim, self.quantum_pct, origin)
        skip = record.skip
        return float(np.sqrt(np.mean((record.pv_pct[skip:] - sim[skip:]) ** 2)))


@dataclass(frozen=True)
class Candidate:
    cause: str
    parameters: dict[str, float]
    error_pct: float | None
    criterion: float | None
    delta_criterion: float | None
    """Against the model the cause was tried on: negative is better."""
    accepted: bool = False
    identifiable: bool = True
    note: str = ""


@dataclass(frozen=True)
class Diagnosis:
    base: Model
    extended: Model
    candidates: dict[str, Candidate]
    steps: list[dict[str, Candidate]]
    base_friction: Friction
    friction: Friction
    linear_valve_delta: float
    """Criterion of a valve without stiction minus the extended model's (positive: stiction earns its place)."""
    notes: list[str] = field(default_factory=list)

    @property
    def causes(self) -> tuple[str, ...]:
        return self.extended.causes

    def parameters(self) -> dict[str, float]:
        return cause_parameters(self.extended)

    def gain_pct(self, record: Record) -> float:
        """How much the extended model's fit error improves on the canonical's, %."""
        base, ext = self.base.error_pct(record), self.extended.error_pct(record)
        return float(100.0 * (1.0 - ext / base)) if base > 0 else 0.0


def cause_parameters(model: Model) -> dict[str, float]:
    h = model.hypothesis
    out: dict[str, float] = {}
    for cause in model.causes:
        if cause == "dead_time":
            out["dead_time_s"] = h.dynamics.dead_time_s
        elif cause == "sensor_lag":
            out["sensor_tau_s"] = h.dynamics.sensor_tau_s
        elif cause == "process_type":
            out["time_constant_s"] = float(h.dynamics.time_constant_s)
        elif cause == "actuator_lag":
            out["actuator_tau_s"] = h.actuator_tau_s
        elif cause == "process_gain":
            out["gain_ratio"] = model.fit.gain_ratio
        elif cause == "external_oscillation":
            out["osc_period_s"] = float(h.osc_period_s)
            out["osc_amplitude_pct"] = model.load_amplitude_pct
        elif cause == "quantization":
            out["quantum_pct"] = float(model.quantum_pct)
    return out


# --- the searches: how each cause changes a hypothesis, and where its parameter is looked for ---


APPLY: dict[str, Callable[[Hypothesis, float], Hypothesis]] = {
    "dead_time": lambda h, v: replace(h, dynamics=replace(h.dynamics, dead_time_s=v)),
    "sensor_lag": lambda h, v: replace(h, dynamics=replace(h.dynamics, sensor_tau_s=v)),
    "process_type": lambda h, v: replace(h, dynamics=replace(h.dynamics, time_constant_s=v)),
    # a plant loop differs from the level loop in gain and type at once: neither helps alone
    "process_gain+process_type": lambda h, v: replace(
        h, gain_free=True, dynamics=replace(h.dynamics, time_constant_s=v)
    ),
    "actuator_lag": lambda h, v: replace(h, actuator_tau_s=v),
    "process_gain": lambda h, v: replace(h, gain_free=True),
    "external_oscillation": lambda h, v: replace(h, osc_period_s=v),
}


def _grid(cause: str, record: Record, current: Model) -> np.ndarray:
    ts, span = record.ts_s, record.n * record.ts_s
    if cause == "dead_time":  # fine: a fractional delay splits every slip's flow between two samples
        return ts * np.arange(0.1, 12.01, 0.1)
    if cause in ("sensor_lag", "actuator_lag"):
        return ts * np.geomspace(0.3, 20, 18)
    if cause in ("process_type", "process_gain+process_type"):
        return np.geomspace(0.05 * ts, span / 3, 18)  # longer lags than a third of the record read as integrating
    if cause == "process_gain":
        return np.array([1.0])
    if cause == "external_oscillation":
        scan = np.geomspace(10 * ts, span / 2.5, 40)
        peaks = residual_periods(record, current.fit)
        return np.unique(np.concatenate([scan, peaks[peaks >= 10 * ts]]))
    raise ValueError(cause)


def residual_periods(record: Record, vf: ValveFit, count: int = 4) -> np.ndarray:
    """Periods [s] of the strongest peaks of the residual's spectrum (as PV levels), longest first."""
    resid = record.target - vf.fit.prediction
    n = resid.size
    spec = np.abs(np.fft.rfft(resid * np.hanning(n))) ** 2
    freq = np.fft.rfftfreq(n, record.ts_s)
    lo = np.searchsorted(freq, 3.0 / (n * record.ts_s))  # at least three cycles in the record
    level = spec[1:] / np.maximum(np.abs(1 - np.exp(-2j * np.pi * freq[1:] * record.ts_s)) ** 2, 1e-12)
    level = np.concatenate([[0.0], level])
    level[:lo] = 0
    peaks = np.flatnonzero((level[1:-1] > level[:-2]) & (level[1:-1] >= level[2:])) + 1
    peaks = peaks[np.argsort(level[peaks])[::-1][:count]]
    return np.sort(1.0 / freq[peaks])[::-1] if peaks.size else np.zeros(0)


def _between(grid: np.ndarray, best: int) -> np.ndarray:
    """Two points either side of ``grid[best]``, a third of the way to its neighbours."""
    lo = grid[best - 1] if best > 0 else grid[best] * 0.6
    hi = grid[best + 1] if best + 1 < grid.size else grid[best] * 1.5
    v = grid[best]
    return np.array([v - (v - lo) / 3, v + (hi - v) / 3])


class Fitter:
    """Fits of one record, with the stem paths read under each process hypothesis kept for reuse."""

    def __init__(self, record: Record):
        self.record = record
        self.reader = StemReader(record.pv_pct, record.ts_s)

    def paths(self, keys: list[tuple[Dynamics, float | None]]):
        """Stem paths under (dynamics, external oscillation period) hypotheses."""
        return self.reader.paths(keys)

    def fast(self, hyps: list[Hypothesis], own_paths: bool = True) -> list[tuple[ValveFit, float]]:
        """First-pass fits (every slip as read): (fit, criterion) each.

        ``own_paths=False`` reads the slips without the external oscillation (a quick scan of periods).
        """
        out = []
        keys = [(h.dynamics, h.osc_period_s if own_paths else None) for h in hyps]
        for h, p in zip(hyps, self.paths(keys), strict=True):
            vf = fit_valve(self.record, h, p, search="quick")
            out.append((vf, criterion(vf.rss, vf.n_params, self.record.n_fit)))
        return out

    def with_slips(self, hyp: Hypothesis, slips) -> ValveFit | None:
        """``hyp`` fitted with given slips (no search)."""
        from ident.fit import refit

        return refit(self.record, hyp, slips)

    def full(self, hyp: Hypothesis, start: ValveFit | None = None) -> tuple[ValveFit, float]:
        """The full fit; ``start``, a fitted valve (the current model's), is searched from as well."""
        valve = None if start is None else (start.band_pct, start.stop_pct, start.level0_pct)
        path = self.paths([(hyp.dynamics, hyp.osc_period_s)])[0]
        vf = fit_valve(self.record, hyp, path, search="full", start=valve)
        return vf, criterion(vf.rss, vf.n_params, self.record.n_fit)


FULL_FITS_PER_CAUSE = 3
CAUSES_FITTED_IN_FULL = 2
MAX_FULL_CAUSES = 4


@dataclass(frozen=True)
class Screened:
    cause: str
    grid: np.ndarray
    criteria: np.ndarray
    fits: list[ValveFit]


OSC_RESCREENED = 3


def _screen(fitter: Fitter, cause: str, current: Model) -> Screened | None:
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


def _local_minima(c: np.ndarray, count: int) -> list[int]:
    """Indices of the ``count`` lowest local minima of ``c``."""
    if c.size == 1:
        return [0]
    left = np.concatenate([[np.inf], c[:-1]])
    right = np.concatenate([c[1:], [np.inf]])
    idx = np.flatnonzero((c <= left) & (c <= right))
    return [int(i) for i in idx[np.argsort(c[idx])][:count]]


def _fit_in_full(fitter: Fitter, sc: Screened, current: Model) -> Model:
    """The screening curve's best local minima, and points beside the best, fitted in full."""
    minima = _local_minima(sc.criteria, FULL_FITS_PER_CAUSE)
    values = [float(sc.grid[i]) for i in minima]
    if sc.cause != "process_gain" and sc.grid.size > 1:
        values += [float(v) for v in _between(sc.grid, minima[0])]
    if "process_type" in sc.cause:  # a lag as long as the grid's longest is no lag the record can tell
        values = [v for v in values if v < 0.999 * sc.grid.max()] or [float(sc.grid[-2])]
    fits = [(v, *fitter.full(APPLY[sc.cause](current.hypothesis, v), current.fit)) for v in dict.fromkeys(values)]
    value, vf, ic = min(fits, key=lambda f: f[2])
    hyp = APPLY[sc.cause](current.hypothesis, value)
    amplitude = fit.load_amplitude_pct(fitter.record, vf) if hyp.osc_period_s else current.load_amplitude_pct
    return Model(hyp, vf, ic, (*current.causes, *_names(sc.cause)), current.quantum_pct, None, amplitude)


def _names(move: str) -> tuple[str, ...]:
    """The catalogue causes a move of the search names (one, or two searched together)."""
    return tuple(move.split("+"))


def _baseline(fitter: Fitter, current: Model, tried: Model) -> Model:
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


ANCHORS = 8


def _quantised(record: Record, current: Model, q: float) -> Model:
    """The current model's one-sample predictions snapped to the record's lattice.

    A prediction from the last stored PV alone carries that sample's rounding error (up to half a
    step); the model carries the last ``ANCHORS`` stored samples forward to the same instant and
    averages them, so that the rounding errors, which differ from sample to sample, average out.
    """
    origin = float(record.pv_pct[np.argmin(np.abs(record.pv_pct))])
    h, start = record.horizon, record.skip
    pred = current.fit.fit.prediction  # model of PV[k] - PV[k - h] for the compared samples
    n = pred.size
    actual = record.pv_pct[start + h : start + h + n]
    # the model's own trajectory (one-step changes accumulated); offsets between it and the data average
    traj = np.cumsum(pred)
    offset = actual - traj
    kernel = np.ones(ANCHORS) / ANCHORS
    smoothed = np.convolve(offset, kernel, mode="full")[: offset.size]
    ready = np.arange(n) >= ANCHORS  # the average of the last ANCHORS offsets, known before sample k
    level = np.where(ready, np.concatenate([[np.nan], smoothed[:-1]]) + traj, np.nan)
    predicted = lattice.snap(level, q, origin)
    err = actual - predicted
    err = err[ready]
    rss = float(np.sum(err**2)) * n / max(err.size, 1)
    n_params = current.fit.n_params + 1
    return Model(
        current.hypothesis,
        current.fit,
        criterion(rss, n_params, record.n_fit),
        (*current.causes, "quantization"),
        q,
        rss,
        current.load_amplitude_pct,
    )


def _forward_step(fitter: Fitter, current: Model, remaining: list[str]) -> tuple[dict[str, Candidate], Model]:
    """Try every remaining cause on ``current``; the best one is accepted if it earns its parameters."""
    record = fitter.record
    screened = {c: sc for c in remaining if (sc := _screen(fitter, c, current)) is not None}
    tried = {c: Candidate(c, {}, None, None, None, note="nothing to fit") for c in remaining if c not in screened}
    ranked = sorted(screened, key=lambda c: screened[c].criteria.min())
    # in full: the best screened few, and every cause whose first-pass fit beats the current model's
    ((_, current_read),) = fitter.fast([current.hypothesis])
    chosen = ranked[:CAUSES_FITTED_IN_FULL] + [c for c in ranked if screened[c].criteria.min() < current_read]
    models = {c: _fit_in_full(fitter, screened[c], current) for c in list(dict.fromkeys(chosen))[:MAX_FULL_CAUSES]}
    # the current model at its best: a cause must not get the credit for a better valve fit its search found
    reference = min([current.criterion, *(_baseline(fitter, current, m).criterion for m in models.values())])
    for c in ranked:
        if c in models:
            m = models[c]
            params = {k: v for k, v in cause_parameters(m).items() if k in _params_of(c)}
            tried[c] = Candidate(c, params, m.error_pct(record), m.criterion, m.criterion - reference)
        else:
            sc = screened[c]
            i = int(np.argmin(sc.criteria))
            hyp = APPLY[c](current.hypothesis, float(sc.grid[i]))
            m = Model(hyp, sc.fits[i], float(sc.criteria[i]), (*current.causes, *_names(c)))
            params = {k: v for k, v in cause_parameters(m).items() if k in _params_of(c)}
            tried[c] = Candidate(
                c, params, m.error_pct(record), None, None, note="screened out: first-pass fit far behind the best"
            )
    if not models:
        return tried, current
    winner = min(models, key=lambda c: models[c].criterion)
    if reference - models[winner].criterion > MARGIN:
        tried[winner] = replace(tried[winner], accepted=True)
        return tried, models[winner]
    return tried, current


def diagnose(record: Record, max_causes: int = MAX_CAUSES) -> Diagnosis:
    """Forward selection over the catalogue from the canonical loop (see the module's docstring)."""
    fitter = Fitter(record)
    vf, ic = fitter.full(Hypothesis())
    base = current = Model(Hypothesis(), vf, ic)
    steps: list[dict[str, Candidate]] = []
    q = lattice.quantum(record.pv_pct)
    remaining = list(SEARCHED)
    while remaining and len(current.causes) < max_causes:
        step, current = _forward_step(fitter, current, remaining)
        steps.append(step)
        accepted = [c for c, cand in step.items() if cand.accepted]
        if not accepted:
            break
        named = set(_names(accepted[0]))
        remaining = [m for m in remaining if not named & set(_names(m))]
    if q is not None:
        qm = _quantised(record, current, q)
        accepted = current.criterion - qm.criterion > MARGIN
        steps[-1]["quantization"] = Candidate(
            "quantization",
            {"quantum_pct": q},
            qm.error_pct(record),
            qm.criterion,
            qm.criterion - current.criterion,
            accepted,
        )
        if accepted:
            current = qm
    _, linear_ic = fitter.full(replace(current.hypothesis, linear_valve=True))
    candidates = _first_look(steps)
    candidates["deadband"] = Candidate(
        "deadband",
        {},
        None,
        None,
        None,
        identifiable=False,
        note="a deadband before a sticky valve widens the band and fd by half its width: "
        "indistinguishable from friction, read as part of fs and fd",
    )
    if "quantization" not in candidates:
        candidates["quantization"] = Candidate("quantization", {}, None, None, None, note="PV sits on no lattice")
    return Diagnosis(
        base,
        current,
        candidates,
        steps,
        friction(base.fit, record),
        friction(current.fit, record),
        float(linear_ic - current.criterion),
    )


def _params_of(move: str) -> tuple[str, ...]:
    from sim.extensions import CATALOGUE

    return tuple(p for c in _names(move) for p in CATALOGUE[c])


def _first_look(steps: list[dict[str, Candidate]]) -> dict[str, Candidate]:
    """Each cause as last tried (its latest step), accepted or not."""
    out: dict[str, Candidate] = {}
    for step in steps:
        out.update(step)
    return out
