"""A slow external oscillation, read where it shows: PV's change over several samples, not one.

The fits compare PV's change over ``Record.horizon`` samples, one for a loop whose PV is smooth.  A sine load at
the process input of a period of minutes changes PV by a hundredth of a per cent a sample, under a measurement
noise whose one-sample differences are a hundred times that: the criterion turns the load down although the
period scan finds it to the second and its amplitude to the per cent (wide draws of ``stiction bench diagnose``,
seeds 4242 and the bench's own: loads of 0.35-0.78 % at 220-380 s, 10-35 worse than none over one sample).  The
differenced noise has almost no power at the load's frequency, but the criterion weighs the residual as if it
were white, so over one sample a slow sine cannot earn its parameters; over ``HORIZON`` samples its change is
eight times larger against the same noise.  Those changes overlap, so the criterion there counts one in
``HORIZON`` of them as independent samples.

So after the forward selection (``ident.diagnose``), where it named no load, sine loads are compared again over
``HORIZON`` samples (``scan``): the chosen model with and without the sine, both with the chosen model's own
slips (the sine gets no credit for a better valve).  Where it earns its parameters there, it is named, and the
chosen model is refitted with it, where it also halves PV's simulated error (``ERROR_SHARE``: over eight samples
a lagged model a little off leaves a slow residual a sine absorbs, on 2-5 of 8 lag loops of every seed tried,
where it barely moves the simulated PV).  A period within ``CYCLE_GUARD`` of the loop's own cycle is left alone: a
valve model a little off leaves its residual there, which a sine would absorb (a none loop of seed 4242 read a
load at 106 s beside its cycle of 98 s).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from stiction.ident.cause_fit import osc_scan_periods
from stiction.ident.fit import criterion, refit
from stiction.ident.friction import load_amplitude_pct
from stiction.ident.models import MARGIN, Candidate, Model
from stiction.ident.record import Record

HORIZON = 8
"""Samples over which PV's change is compared for a slow load (chosen on seeds 4242 and 20261122 of the wide
draws among 1, 8 and 32; 32 let a none loop's slow drift through)."""
ERROR_SHARE = 0.5
"""A load named this way must at least halve PV's simulated error (``Model.error_pct``: PV as the model runs it from
OP, the plot's figure).  A real slow load moves PV's level by its whole amplitude, and the loads turned down over
one sample cut that error to 0.11-0.25 of the model's without them; a sine absorbing a lagged model's slow residual
cut it to 0.56-1.0 (seeds 7070, 3131 and 4242 of the wide draws, looked at before choosing; judged on 6161 and 2727)."""
CYCLE_GUARD = 0.2
"""Relative distance from the loop's own cycle period within which no load is named this way."""


def cycle_period_s(record: Record) -> float:
    """The loop's own cycle period from OP's mean crossings (nan where OP crosses its mean fewer than 4 times)."""
    op = record.op_pct - np.mean(record.op_pct)
    crossings = np.flatnonzero(np.diff(np.signbit(op)))
    if crossings.size < 4:
        return float("nan")
    return float(2.0 * np.median(np.diff(crossings)) * record.ts_s)


def near_cycle(period_s: float, cycle_s: float) -> bool:
    return bool(np.isfinite(cycle_s)) and abs(period_s / cycle_s - 1.0) < CYCLE_GUARD


def _criterion_over_horizon(longer: Record, hyp, slips) -> float:
    """``hyp`` refitted with ``slips`` on ``longer`` (PV's change over ``HORIZON`` samples); inf where it cannot be.

    Changes over ``HORIZON`` samples overlap: about one in ``HORIZON`` of them is independent, and the criterion
    counts that many.  Counting all of them, a model a little off, its residual slow, bought a sine on half the
    loops of other causes of two seeds (555 and 9001 of the wide draws: dead time 4 of 8, none 1 of 8, at -2 to
    -57, where the loads turned down over one sample read -300 to -830)."""
    fit = refit(longer, hyp, slips)
    if fit is None:
        return float("inf")
    n = longer.n_fit // HORIZON
    return float(criterion(fit.rss * n / longer.n_fit, fit.n_params, n))


def scan(record: Record, chosen: Model, also: tuple[float, ...] = ()) -> tuple[float, float]:
    """(period, its criterion less the chosen model's) of the best sine load over ``HORIZON`` samples, with the
    chosen model's slips: the periods ``ident.cause_fit.osc_scan_periods`` scans, and ``also``,
    none within ``CYCLE_GUARD`` of the loop's cycle, the best refined in steps of 1 %."""
    longer = replace(record, horizon=HORIZON)
    hyp, slips = chosen.hypothesis, chosen.fit.slips
    base = _criterion_over_horizon(longer, hyp, slips)
    if not np.isfinite(base):
        return float("nan"), float("inf")
    cycle = cycle_period_s(record)

    def best_of(periods) -> tuple[float, float]:
        periods = [float(p) for p in periods if np.isfinite(p) and not near_cycle(p, cycle)]
        if not periods:
            return float("nan"), float("inf")
        c = [_criterion_over_horizon(longer, replace(hyp, osc_period_s=p), slips) for p in periods]
        i = int(np.argmin(c))
        return periods[i], c[i] - base

    period, delta = best_of([*osc_scan_periods(record), *also])
    if np.isfinite(period):
        period, delta = min((period, delta), best_of(period * (1 + np.arange(-4, 5) / 100)), key=lambda x: x[1])
    return period, delta


def named(record: Record, chosen: Model, turned_down: Candidate | None) -> tuple[Model, Candidate] | None:
    """The chosen model with the best slow load (``scan``; the period of ``turned_down``, the last step's
    external-oscillation candidate, among those tried) and its candidate, where the load earns its parameters over
    ``HORIZON`` samples and cuts PV's simulated error to ``ERROR_SHARE`` of the chosen model's or less; else None."""
    hyp = chosen.hypothesis
    if hyp.linear_valve or hyp.osc_period_s or (turned_down is not None and turned_down.accepted):
        return None
    if record.n_fit < 4 * HORIZON:
        return None
    told = None if turned_down is None else turned_down.parameters.get("osc_period_s")
    period_s, delta = scan(record, chosen, () if told is None else (float(told),))
    if not delta < -MARGIN:
        return None
    loaded = replace(hyp, osc_period_s=float(period_s))
    fit = refit(record, loaded, chosen.fit.slips)
    if fit is None:
        return None
    fit = replace(fit, band_pct=chosen.fit.band_pct, band_se=chosen.fit.band_se)
    amplitude = load_amplitude_pct(record, fit)
    model = replace(
        chosen, hypothesis=loaded, fit=fit, criterion=float(criterion(fit.rss, fit.n_params, record.n_fit)),
        causes=(*chosen.causes, "external_oscillation"), load_amplitude_pct=amplitude,
    )  # fmt: skip
    error_pct = model.error_pct(record)  # PV simulated from OP: the costliest figure here, read once
    if not error_pct <= ERROR_SHARE * chosen.error_pct(record):
        return None
    one_sample = model.criterion - chosen.criterion
    note = (f"named on PV's change over {HORIZON} samples, where a slow load stands out of the noise "
            f"({delta:+.1f}); over {record.horizon} sample(s) it reads {one_sample:+.1f}")  # fmt: skip
    cand = Candidate(
        "external_oscillation", {"osc_period_s": float(period_s), "osc_amplitude_pct": amplitude},
        error_pct, model.criterion, delta, accepted=True, note=note,
    )  # fmt: skip
    return model, cand
