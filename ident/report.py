"""A diagnosis as the report users and programs read (``schemas.diagnosis``): pure assembly."""

from __future__ import annotations

import math

import numpy as np

from stiction.detect.features import stuck_travel
from stiction.ident.cause_fit import residual_periods
from stiction.ident.checks import blocking, data_checks, impossible_friction
from stiction.ident.friction import Friction, explained_share
from stiction.ident.models import (
    WITHIN_SAMPLE,
    Diagnosis,
    Model,
    Tie,
    cause_parameters,
    is_lag_line,
    parameter_ranges,
)
from stiction.ident.process import NOMINAL, ranged
from stiction.ident.record import Record
from stiction.ident.trust import (
    band_bound,
    band_doubts,
    dragged,
    explains_none,
    holds_zero,
    stuck_travel_contradicts,
    with_model_error,
    without_uncertainty,
)
from stiction.ident.valve_model import ValveFit
from stiction.schemas import diagnosis as schema

WORSE_SHARE = 0.05
"""An extended model whose simulated error exceeds the canonical's by more than this share is flagged."""
UNFIT_RATIO = 2.0
"""An extended model whose simulation of PV from OP errs more than this many times as much as the canonical model's
describes none of the loops the catalogue's models make, and its friction numbers are withheld.  Over the 288 loops
of `stiction bench diagnose --loops 8` and `... --draws wide --loops 8 [--seed 4242 | 9001]` (one cause each, or
none) the largest ratio was 1.71 (a sensor lag of seed 4242; 1.25 and 1.08 at most on the other wide draws, 1.00 on
the catalogue's), so 2 leaves every one of them its numbers; of the 61 measured loops (`stiction diagnose --json
../shared/data/stictiongpt_plant/csv ../shared/data/damadics_lublin`) one reached it, 2111FIC51001_0610_0004 at
3.18 (the next 1.59): there the one-sample criterion named a process gain 185 times the nominal, a lag of 0.5 s
and a dead time of 90 s, and read S 2.95 +- 1.34 % of span under them, on a loop its authors labelled 0.003
sticky."""


def _opt(x) -> float | None:
    return float(x) if x is not None and math.isfinite(float(x)) else None


def friction_out(f: Friction) -> schema.Friction:
    return schema.Friction(
        s_pct=_opt(f.s_pct),
        j_pct=_opt(f.j_pct),
        s_se_pct=_opt(f.s_se_pct),
        j_se_pct=_opt(f.j_se_pct),
        fs_pct=_opt(f.fs_pct),
        fd_pct=_opt(f.fd_pct),
        fs_se_pct=_opt(f.fs_se_pct),
        fd_se_pct=_opt(f.fd_se_pct),
    )


def process_out(model: Model, record: Record) -> schema.Process:
    h, vf = model.hypothesis, model.fit
    d = h.dynamics
    rate = vf.gain_ratio * NOMINAL.gain
    rate_se = vf.gain_se * NOMINAL.gain
    if d.time_constant_s is None:
        kind, gain, gain_se = "integrating", rate, rate_se
    else:
        # continuous_plant keeps the high-frequency gain: K / (T s + 1) with K = rate * T
        kind, gain, gain_se = "self_regulating", rate * d.time_constant_s, rate_se * d.time_constant_s
    unit = "%/s per %" if kind == "integrating" else "% per %"
    ranges = parameter_ranges(model, record.ts_s)  # every named parameter's, about 95 %
    told = f" +- {gain_se:.2g}" if h.gain_free and math.isfinite(gain_se) else ""  # one standard error, as S and J
    lag = h.actuator_tau_s
    extra = ranged(f", actuator lag {lag:.3g} s", ranges.get("actuator_tau_s")) if lag > 0 else ""
    if d.time_constant_s is not None and d.time_constant_s < WITHIN_SAMPLE * record.ts_s:
        extra += f" (a lag under half the {record.ts_s:.3g} s sample: a static gain, as far as this record shows)"
    return schema.Process(
        kind=kind,
        gain=float(gain),
        gain_se=_opt(gain_se) if h.gain_free else None,
        time_constant_s=d.time_constant_s,
        dead_time_s=d.dead_time_s,
        sensor_tau_s=d.sensor_tau_s,
        actuator_tau_s=h.actuator_tau_s,
        sample_time_s=record.ts_s,
        description=f"{d.describe(ranges)}, gain {gain:.3g}{told} {unit}{extra}",
        pv_explained_share=_opt(explained_share(vf, record)),
    )



def causes_text(report: schema.DiagnosisReport) -> str:
    """The named causes in words, each with its parameters and their ranges (``dead_time (dead_time_s 2.87
    (2.17-3.79))``), as the summary and the plot's title give them; empty where none is named."""
    from stiction.sim.extensions import CATALOGUE

    def params(cause: str) -> str:
        named = [k for k in CATALOGUE.get(cause, ()) if k in report.parameters]
        return ", ".join(ranged(f"{k} {report.parameters[k]:.3g}", report.parameter_ranges.get(k)) for k in named)

    return ", ".join(f"{c} ({params(c)})" for c in report.causes)


def residual_out(vf: ValveFit, record: Record, rss_override: float | None = None) -> schema.Residual:
    resid = record.target - vf.fit.prediction
    tenths = np.array_split(resid, 10)
    power = np.abs(np.fft.rfft(resid - resid.mean())) ** 2
    total = float(power[1:].sum()) or 1.0
    freq = np.fft.rfftfreq(resid.size, record.ts_s)
    peaks = []
    for period in residual_periods(record, vf, count=3):
        k = int(np.argmin(np.abs(freq - 1.0 / period)))
        share = float(power[max(k - 1, 1) : k + 2].sum() / total)
        peaks.append({"period_s": float(period), "share": share})
    return schema.Residual(rms_by_tenth_pct=[float(np.sqrt(np.mean(t * t))) for t in tenths], peaks=peaks)


def valve_check_out(v) -> schema.ValveCheck:
    """``ident.valve_check.ValveCheck`` as reported; S and J only where the stem sticks."""
    return schema.ValveCheck(
        model="sticky" if v.sticky else "linear",
        delta_criterion=v.delta_criterion,
        s_pct=_opt(v.s_pct) if v.sticky else None,
        j_pct=_opt(v.j_pct) if v.sticky else None,
        s_se_pct=_opt(v.s_se_pct) if v.sticky else None,
        j_se_pct=_opt(v.j_se_pct) if v.sticky else None,
        valve=v.valve if v.sticky else None,
        actuator_tau_s=v.actuator_tau_s,
        calibration_gain=v.calibration_gain,
        calibration_offset_pct=v.calibration_offset_pct,
        error_pct=v.error_pct,
    )


def impossible_valve(f: Friction, op_range_pct: float) -> str | None:
    """Why no valve can have this friction, or None (``ident.checks.impossible_friction``)."""
    return impossible_friction(f.s_pct, f.j_pct, f.s_se_pct, f.j_se_pct, op_range_pct)


def _without_friction(f: Friction) -> Friction:
    nan = float("nan")
    return Friction(nan, nan, nan, nan, nan, nan, nan, nan, f.slips_read)


def _worse_course(base_error: float, extended_error: float, unfit: bool) -> str:
    """The warning of an extended model that simulates PV from OP worse than the canonical one (``WORSE_SHARE``), or
    so much worse that its friction is withheld (``unfit``: ``UNFIT_RATIO``)."""
    errors = f"({base_error:.3g} -> {extended_error:.3g} % of span)"
    how, then = (
        (f"{extended_error / base_error:.3g} times as badly as the canonical model {errors}, worse than any model of "
         "the catalogue does on the loops it makes", ", and its friction numbers are withheld")
        if unfit
        else (f"worse than the canonical model {errors}", "; read them with care")
    )  # fmt: skip
    return (
        "the extended model predicts PV better a sample ahead (the criterion that named its causes) but simulates "
        f"it from OP {how}: its causes fit the loop's short-term dynamics, not the record's course{then}"
    )


def shown_ties(ties: list[Tie], f: Friction, withheld: bool, lag_s_sd_pct: float = 0.0) -> list[Tie]:
    """The ties a report gives.  The line along which an actuator's lag and the band trade
    (``ident.ties.lag_band_tie``) describes a band: where none is given, or its interval of two standard
    errors holds 0 (a band the data cannot tell from none, ``ident.trust.band_doubts``), there is no band to trade
    and the line is left out (a healthy level loop cycling under a load, read as a lag of 38 s before a valve with
    a band of 0.15 +- 0.08 %, had its line give 3.7 % at no lag).  S's error without the lag's own doubt
    (``lag_s_sd_pct``, ``ident.ties.lag_widened``) decides: the line is what that doubt is about."""
    s_se = math.sqrt(max(f.s_se_pct**2 - lag_s_sd_pct**2, 0.0)) if math.isfinite(f.s_se_pct) else f.s_se_pct
    told = not holds_zero(f.s_pct, s_se, f.j_pct, f.j_se_pct)
    band = not withheld and math.isfinite(f.s_pct) and math.isfinite(f.s_se_pct) and told
    return [t for t in ties if band or not is_lag_line(t)]


def diagnosis_report(
    loop_id: str,
    record: Record,
    d: Diagnosis,
    warnings: list[str] | None = None,
    valve_check: schema.ValveCheck | None = None,
    sp_pct: np.ndarray | None = None,
) -> schema.DiagnosisReport:
    f = d.friction
    problems = data_checks(record.op_pct, record.pv_pct)
    notes = [c.message for c in problems] + list(warnings or []) + [n for n in d.notes]
    if blocking(problems):
        notes.append("the data cannot show a valve's friction (above): its numbers are withheld")
    op_range = float(np.ptp(record.op_pct))
    linear = d.extended.hypothesis.linear_valve
    for which, fr in (("extended", None if linear else f), ("canonical", d.base_friction)):
        why = impossible_valve(fr, op_range) if fr is not None else None
        if why:
            notes.append(f"{which} model: {why}; its friction numbers are withheld")
    base_error, extended_error = d.base.error_pct(record), d.extended.error_pct(record)
    unfit = not linear and base_error > 0 and extended_error > UNFIT_RATIO * base_error
    if unfit:
        notes.append(_worse_course(base_error, extended_error, unfit=True))
    withheld = linear or impossible_valve(f, op_range) or blocking(problems) or unfit
    slips = d.extended.fit.slips
    moved = None if withheld else dragged(int(slips.read.sum()), int(slips.at.size), record.n)
    if moved:  # no stuck phase to read a band from (ident.trust)
        notes.append(moved)
        withheld = True
    bound = None if withheld else band_bound(f)  # the stop held at its bound: S is a bound (ident.trust)
    if bound is not None:
        notes.append(bound)
        withheld = True
    # the fit's errors assume its model is right; a real loop's process is only near one (ident.sizing)
    f = _without_friction(f) if withheld else with_model_error(f)
    unsure = None if withheld else without_uncertainty(f)
    if unsure:
        notes.append(unsure)
        f, withheld = _without_friction(f), True
    if not withheld:  # a band read: does the OP travel over which PV stood still allow it?
        travel = stuck_travel(record.op_pct, record.pv_pct, sp_pct)
        contradicted = stuck_travel_contradicts(f.s_pct, f.s_se_pct, travel)
        if contradicted:
            notes.append(contradicted)
            f = _without_friction(f)
    base = d.base_friction
    unusable = impossible_valve(base, op_range) or blocking(problems) or without_uncertainty(base)
    base_friction = _without_friction(base) if unusable else base
    params = cause_parameters(d.extended)
    candidates = {
        c: schema.CauseCandidate(
            cause=c,
            parameters={k: float(v) for k, v in cand.parameters.items() if math.isfinite(v)},
            error_pct=_opt(cand.error_pct),
            criterion=_opt(cand.criterion),
            delta_criterion=_opt(cand.delta_criterion),
            accepted=cand.accepted,
            identifiable=cand.identifiable,
            note=cand.note,
        )
        for c, cand in d.candidates.items()
    }
    if d.causes and not unfit and extended_error > base_error * (1 + WORSE_SHARE):
        notes.append(_worse_course(base_error, extended_error, unfit=False))
    process = process_out(d.extended, record)
    none_explained = None if blocking(problems) else explains_none(process)
    if none_explained:
        notes.append("the identified model " + none_explained)
    if not withheld:
        notes += band_doubts(f.s_pct, f.s_se_pct, process, f.j_pct, f.j_se_pct)
    if d.linear_valve_delta <= 0 and not d.notes and not blocking(problems):
        notes.append(
            "a valve that does not stick explains PV as well: the friction numbers are not supported by the data"
        )
    return schema.DiagnosisReport(
        loop_id=loop_id,
        n_samples=record.n,
        sample_time_s=record.ts_s,
        cause=d.causes[0] if d.causes else "none",
        causes=list(d.causes),
        cannot_tell=[
            schema.CannotTell(
                named=t.named,
                alternative=t.alternative,
                delta_criterion=_opt(t.delta_criterion),
                parameters={k: float(v) for k, v in t.parameters.items() if math.isfinite(v)},
                note=t.note,
            )
            for t in shown_ties(d.ties, f, withheld, d.lag_s_sd_pct)
        ],
        parameters={k: float(v) for k, v in params.items() if math.isfinite(v)},
        parameter_ranges={
            k: r for k, r in d.parameter_ranges(record.ts_s).items() if k in params and math.isfinite(params[k])
        },
        candidates=candidates,
        base_error=base_error,
        extended_error=extended_error,
        gain_pct=d.gain_pct(record),
        **friction_out(f).model_dump(),
        base_friction=friction_out(base_friction),
        process=process,
        stiction_delta_criterion=float(d.linear_valve_delta),
        slips=int(d.extended.fit.slips.at.size),
        uses_mv=valve_check is not None,
        valve_check=valve_check,
        residual_base=residual_out(d.base.fit, record),
        residual_extended=residual_out(d.extended.fit, record),
        warnings=notes,
    )


MAX_SAMPLES = 3600
"""Longer records are diagnosed on their last MAX_SAMPLES samples (the fits grow with the record)."""
MIN_SAMPLES = 100


def diagnose_loop(
    name: str,
    op: np.ndarray,
    pv: np.ndarray,
    ts_s: float,
    mv: np.ndarray | None = None,
    warnings: tuple[str, ...] | list[str] = (),
    last: int | None = None,
    max_causes: int | None = None,
    sp: np.ndarray | None = None,
    threads: int = 1,
):
    """Diagnose one measured loop as ``stiction diagnose`` does: the last ``last`` samples (default
    up to MAX_SAMPLES, with a warning when more were given), the valve checked against a measured
    stem where there is one.  Returns (report, record, diagnosis); raises InputError on a record
    too short to diagnose."""
    from stiction.ident.diagnose import MAX_CAUSES, diagnose
    from stiction.ident.record import choose_horizon
    from stiction.ident.valve_check import check_valve
    from stiction.schemas.errors import InputError

    keep = last or MAX_SAMPLES
    warnings = list(warnings)
    if op.size > keep and last is None:
        warnings.append(f"{op.size} samples: diagnosed the last {keep} (--last to choose)")
    op, pv = op[-keep:], pv[-keep:]
    mv = mv[-keep:] if mv is not None else None
    sp = np.asarray(sp, float)[-keep:] if sp is not None else None
    sp = sp if sp is not None and sp.size == op.size else None
    if op.size < MIN_SAMPLES:
        raise InputError(f"{op.size} samples, need at least {MIN_SAMPLES} to diagnose")
    record = Record(op, pv, ts_s, horizon=choose_horizon(pv))
    d = diagnose(record, max_causes=MAX_CAUSES if max_causes is None else max_causes, threads=threads)
    check = valve_check_out(check_valve(op, mv, ts_s)) if mv is not None else None
    return diagnosis_report(name, record, d, warnings, check, sp), record, d
