"""A diagnosis's models: a hypothesis with its valve fit and criterion, the candidates of a forward
step, the diagnosis itself, and the catalogue's parameters a model names (``ident.diagnose``)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from stiction.ident.friction import Friction, simulated_pv
from stiction.ident.record import Record
from stiction.ident.valve_model import Hypothesis, ValveFit

MAX_CAUSES = 4
SPREAD_FIELDS = ("band", "stop", "s", "j")
"""What ``ident.cause_fit.spread`` reads of each rival fit, % of span: the static band (fs / 12), the stop (fd / 12),
Choudhury's S and J (``sim.valve.band_and_jump_pct``)."""
NO_SPREAD = (0.0,) * len(SPREAD_FIELDS)
MARGIN = 0.0
"""Criterion improvement a cause must bring beyond its parameter's own price."""
TIE_CRITERION = 2.0
"""Two models whose Schwarz criteria differ by no more than this explain the data equally: a
difference under 2 is evidence "not worth more than a bare mention" (Kass & Raftery 1995, the
scale BIC differences are read on).  Chosen from the literature, not from the benchmark."""


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
    friction moves over the cause parameters and the rival causes the data allow (``ident.cause_fit.spread``)."""
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
    se: dict[str, float] = field(default_factory=dict)
    """Standard errors of ``parameters`` where the fit gives them (the process gain's)."""


@dataclass(frozen=True)
class Tie:
    """Two answers the data cannot tell apart: the one named (a cause, or ``none``: nothing beyond the
    causes named before it) and an ``alternative`` that explains PV as well, with the alternative's
    criterion minus the named one's (``delta_criterion``, None where the limit is the record's, not a
    fit's) and the alternative's parameters."""

    named: str
    alternative: str
    delta_criterion: float | None
    parameters: dict[str, float]
    note: str


def is_lag_line(tie) -> bool:
    """The actuator lag's line (``ident.ties.lag_band_tie``) among a diagnosis's ``Tie`` s or a report's
    ``cannot_tell``: the lag named, and the same lag with another band as the alternative."""
    return tie.named == tie.alternative == "actuator_lag"


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
    ties: list[Tie] = field(default_factory=list)
    """Answers the data cannot tell from the one given (``ident.ties.ties``)."""
    lag_s_sd_pct: float = 0.0
    """The part of ``friction``'s S error that is the actuator lag's doubt carried along the line on which lag and
    band trade (``ident.ties.lag_widened``); 0 where no lag is named."""

    @property
    def causes(self) -> tuple[str, ...]:
        return self.extended.causes

    def parameters(self) -> dict[str, float]:
        return cause_parameters(self.extended)

    def parameter_ranges(self, ts_s: float) -> dict[str, tuple[float, float]]:
        return parameter_ranges(self.extended, ts_s)

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


RANGE_LOG = {
    "dead_time_s": 0.28,
    "actuator_tau_s": 1.0,
    "sensor_tau_s": 0.28,
    "time_constant_s": 0.15,
    "osc_period_s": 0.06,
    "osc_amplitude_pct": 0.25,
    "gain_ratio": 0.02,
}
"""How far (in log) a named cause's parameter lay from the truth on simulated loops, 95th percentile: each named
parameter's range is its value times exp(-k) to exp(k) (``parameter_ranges``).  The criterion's own curvature over
a parameter is no uncertainty: where the search fits the slips afresh at each value, the criterion is jagged, and
ranges from its curvature held the truth for 0-60 % of lags and dead times (a script outside the tree, seed 777).
Measured on ``stiction bench diagnose --draws wide`` loops of seeds 777-782 (8 loops a cause a seed, one cause
each; the 18-46 loops a parameter where its cause was named), never the bench's seed; judged there after.  The
median errors were far smaller (log 0.004-0.04; the actuator's lag 0.27): the range is what a 95 % claim needs,
not the typical error.  An actuator lag's is wide (a factor of e) because a lag trades with the band
(``ident.ties.lag_band_tie``)."""


WITHIN_SAMPLE = 0.5
"""A first-order lag shorter than this many sample times acts within one sample (its pole exp(-ts/tau) under
0.14): the record cannot tell it from any shorter lag or from none, and its range runs from 0."""
LAGS = ("time_constant_s", "sensor_tau_s", "actuator_tau_s")


def parameter_ranges(model: Model, ts_s: float) -> dict[str, tuple[float, float]]:
    """About 95 % ranges of the named causes' parameters (``RANGE_LOG``); the process gain's also holds its fit's
    two standard errors, and a lag within a sample (``WITHIN_SAMPLE``) runs from 0 to at least that.  The quantum
    is read off the record's lattice, not fitted: no range."""
    out = {}
    for name, value in cause_parameters(model).items():
        k = RANGE_LOG.get(name)
        if k is None or not (np.isfinite(value) and value > 0):
            continue
        lo, hi = value * np.exp(-k), value * np.exp(k)
        if name == "gain_ratio" and np.isfinite(model.fit.gain_se):
            lo, hi = min(lo, value - 2 * model.fit.gain_se), max(hi, value + 2 * model.fit.gain_se)
        if name in LAGS and value < WITHIN_SAMPLE * ts_s:
            lo, hi = 0.0, max(hi, WITHIN_SAMPLE * ts_s)
        out[name] = (float(lo), float(hi))
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
