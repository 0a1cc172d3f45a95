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

from ident import checks, lattice
from ident.fit import criterion, fit_valve
from ident.friction import Friction, effective_samples, friction, load_amplitude_pct, simulated_pv
from ident.process import Dynamics
from ident.record import Record, process_sign
from ident.stem import StemReader
from ident.valve_model import Hypothesis, ValveFit
from sim.valve import PCT_OF_500LBF_PER_PCT_OF_SPAN, band_and_jump_pct

MAX_CAUSES = 4
SPREAD_FIELDS = ("band", "stop", "s", "j")
"""What ``_spread`` reads of each rival fit, % of span: the static band (fs / 12), the stop (fd / 12),
Choudhury's S and J (``sim.valve.band_and_jump_pct``)."""
NO_SPREAD = (0.0,) * len(SPREAD_FIELDS)
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
    spread: tuple[float, ...] = NO_SPREAD
    """Model uncertainty of ``SPREAD_FIELDS``, % of span, beyond the fit's own covariance: how much the
    friction moves over the cause parameters and the rival causes the data allow (``_spread``)."""
    profile: tuple[tuple[float, ValveFit, float], ...] = ()
    """(value, fit, criterion) of the last cause's parameter where it was fitted in full."""

    @property
    def rss(self) -> float:
        return self.fit.rss if self.rss_override is None else self.rss_override

    def step_error_pct(self, record: Record) -> float:
        """RMS of the one-sample PV prediction error (what the criterion weighs), % of span."""
        return float(np.sqrt(self.rss / record.n_fit))

    def error_pct(self, record: Record) -> float:
        """RMS difference between measured PV and PV as the model simulates it from OP, % of span.

        The simulation is open loop in the process (its offset and drift fitted): the figure a
        plant engineer sees in the plot.  For a record on a lattice, the rounding's own variance
        (q^2/12) is taken out: no model of the loop can remove it.
        """
        sim = simulated_pv(self.fit, record)
        skip = record.skip
        mse = float(np.mean((record.pv_pct[skip:] - sim[skip:]) ** 2))
        if self.quantum_pct:
            mse = max(mse - self.quantum_pct**2 / 12.0, 1e-12 * mse)
        return float(np.sqrt(mse))


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
        self.sign = process_sign(record.op_pct, record.pv_pct)

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
        out = []
        keys = [(h.dynamics, h.osc_period_s if own_paths else None) for h in hyps]
        for h, p in zip(hyps, self.paths(keys), strict=True):
            vf = fit_valve(self.record, h, p, search="quick")
            out.append((vf, self._criterion(vf)))
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
        return vf, self._criterion(vf)


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
    amplitude = load_amplitude_pct(fitter.record, vf) if hyp.osc_period_s else current.load_amplitude_pct
    own = _spread(fitter.record, [(f, c) for _, f, c in fits])
    return Model(
        hyp,
        vf,
        ic,
        (*current.causes, *_names(sc.cause)),
        current.quantum_pct,
        None,
        amplitude,
        _combined(current.spread, own),
        tuple(sorted(fits, key=lambda f: f[0])),
    )


REFINE_STEPS = 2


def _refined(fitter: Fitter, model: Model, cause: str, current: Model) -> Model:
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
        value = float(np.exp(x))
        hyp = APPLY[cause](current.hypothesis, value)
        vf, ic = fitter.full(hyp, current.fit)
        points.append((value, vf, ic))
        if ic < best.criterion:
            amplitude = load_amplitude_pct(fitter.record, vf) if hyp.osc_period_s else best.load_amplitude_pct
            best = replace(best, hypothesis=hyp, fit=vf, criterion=ic, load_amplitude_pct=amplitude)
    own = _spread(fitter.record, [(f, c) for _, f, c in points])
    return replace(best, spread=_combined(current.spread, own), profile=tuple(sorted(points, key=lambda p: p[0])))


def _valve_of(vf: ValveFit) -> tuple[float, float, float, float]:
    """(static band, stop, S, J) of a fit, % of span (nan where not read)."""
    band = vf.band_pct
    stop = band - vf.jump_pct if np.isfinite(vf.jump_pct) else vf.stop_pct
    s, j = band_and_jump_pct(band * PCT_OF_500LBF_PER_PCT_OF_SPAN, stop * PCT_OF_500LBF_PER_PCT_OF_SPAN)
    return band, stop, float(s), float(j)


def _spread(record: Record, fits: list[tuple[ValveFit, float]]) -> tuple[float, ...]:
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


def _combined(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, ...]:
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


ROUNDING_SHARE = 0.1
"""Share of the remaining error the rounding must account for to be named."""


def _quantised(record: Record, current: Model, q: float) -> Model | None:
    """The record's lattice as a cause: the part of the model's error that the rounding itself adds.

    Stored values on a lattice of step q carry a rounding error of variance q^2/12 that no model of
    the loop can remove.  The lattice is read from the values (``ident.lattice``); it is named when
    its variance is at least ``ROUNDING_SHARE`` of the model's remaining error, and the extended
    error is what remains once it is taken out.  Its criterion treats that variance as known noise.
    """
    error = current.error_pct(record)
    rounding = q * q / 12.0
    if error <= 0 or rounding < ROUNDING_SHARE * error**2:
        return None
    left = max(error**2 - rounding, 1e-12 * error**2)
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
        models[winner] = _refined(fitter, models[winner], winner, current)
        m = models[winner]
        params = {k: v for k, v in cause_parameters(m).items() if k in _params_of(winner)}
        tried[winner] = Candidate(
            winner, params, m.error_pct(record), m.criterion, m.criterion - reference, accepted=True
        )
        # the rivals the data cannot rule out (other causes, and none) widen the friction's uncertainty
        rivals = _spread(record, [(current.fit, current.criterion)] + [(m.fit, m.criterion) for m in models.values()])
        return tried, replace(models[winner], spread=_combined(models[winner].spread, rivals))
    return tried, current


def _select(fitter: Fitter, start: Model, max_causes: int) -> tuple[Model, list[dict[str, Candidate]]]:
    """Forward selection over the catalogue from ``start``, then the record's lattice."""
    record = fitter.record
    current, steps = start, []
    remaining = list(SEARCHED)
    while remaining and len(current.causes) < max_causes:
        step, current = _forward_step(fitter, current, remaining)
        steps.append(step)
        accepted = [c for c, cand in step.items() if cand.accepted]
        if not accepted:
            break
        named = set(_names(accepted[0]))
        remaining = [m for m in remaining if not named & set(_names(m))]
    q = lattice.quantum(record.pv_pct)
    qm = _quantised(record, current, q) if q is not None else None
    if qm is not None:
        accepted = current.criterion - qm.criterion > MARGIN
        if not steps:
            steps.append({})
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
    return current, steps


def diagnose(record: Record, max_causes: int = MAX_CAUSES) -> Diagnosis:
    """Forward selection over the catalogue from the canonical loop (see the module's docstring).

    Twice: with the sticky valve and with a valve that follows OP (no stiction).  A loop whose
    valve does not stick is no canonical loop either, and its process must still be read; the
    better of the two by the criterion is the diagnosis, and their difference says whether
    stiction earns its place.
    """
    fitter = Fitter(record)
    vf, ic = fitter.full(Hypothesis())
    base = Model(Hypothesis(), vf, ic)
    if checks.flat(record.pv_pct):
        # a dead sensor or a loop at rest (``ident.checks`` names it): no model has anything to explain
        return Diagnosis(base, base, {}, [], friction(vf, record), friction(vf, record), 0.0, [])
    sticky, sticky_steps = _select(fitter, base, max_causes)
    linear_hyp = Hypothesis(linear_valve=True)
    vf_linear, ic_linear = fitter.full(linear_hyp)
    linear, linear_steps = _select(fitter, Model(linear_hyp, vf_linear, ic_linear), max_causes)
    stiction_delta = float(linear.criterion - sticky.criterion)
    chosen, steps = (sticky, sticky_steps) if stiction_delta > 0 else (linear, linear_steps)
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
        q = lattice.quantum(record.pv_pct)
        note = "PV sits on no lattice" if q is None else f"PV is stored in steps of {q:.3g} %: too fine to matter"
        candidates["quantization"] = Candidate(
            "quantization", {} if q is None else {"quantum_pct": q}, None, None, None, note=note
        )
    return Diagnosis(
        base,
        chosen,
        candidates,
        steps,
        friction(base.fit, record),
        widened(friction(chosen.fit, record), chosen.spread),
        stiction_delta,
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
