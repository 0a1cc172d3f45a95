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

from dataclasses import replace

import numpy as np

from stiction.ident import checks, lattice, slow_load
from stiction.ident.cause_fit import (
    CAUSES_FITTED_IN_FULL,
    MAX_FULL_CAUSES,
    SEARCHED,
    Fitter,
    baseline,
    best_of_full,
    combined,
    full_values,
    names,
    quantised,
    refined,
    screen,
    spread,
    told_lag_s,
    widened,
)
from stiction.ident.friction import Friction, friction, stem_path
from stiction.ident.models import (
    APPLY,
    MARGIN,
    MAX_CAUSES,
    RANGE_LOG,
    TIE_CRITERION,
    Candidate,
    Diagnosis,
    Model,
    Tie,
    cause_parameters,
)
from stiction.ident.record import Record
from stiction.ident.valve_model import Hypothesis
from stiction.sim.valve import PCT_OF_500LBF_PER_PCT_OF_SPAN

SCREEN_BLIND = ("dead_time", "process_gain")
"""Causes fitted in full whatever their screening says: a dead time's first-pass fit reads the slips where the
record shows them, a sample or two off the delayed stem's, and its full fit moves them (``ident.fit``); on
the wide draws the screen put a dead time of 1.0 s 51-78 behind none, the full fit at it 83 ahead.  A process
gain's first pass keeps the slips read at the nominal gain, which a gain of 0.75 reads wrong: on seed 9191's wide
draws its screen lay 40 behind none's, and the full fit, 1 behind the canonical's, was never made, so the report said
nothing of a gain the data allow as well (2026-11-27; `stiction bench diagnose --draws wide --causes process_gain`,
chosen on seed 9191, judged on 8383, 4747, 3131, 5757, 6262: gains named 33 -> 35 of 40, named or tied 34 -> 37,
their fs/fd 2.73 -> 2.28 and 2.28 -> 0.43 pp where it moved, one self-regulating lag of 330 s (past the 167 s the
record tells) now none with the lag's tie, since the gain's full fit read slips the canonical model fits as well; no
canonical loop given a cause)."""


def _forward_step(fitter: Fitter, current: Model, remaining: list[str]) -> tuple[dict[str, Candidate], Model]:
    """Try every remaining cause on ``current``; the best one is accepted if it earns its parameters."""
    record = fitter.record
    screened = {c: sc for c in remaining if (sc := screen(fitter, c, current)) is not None}
    tried = {c: Candidate(c, {}, None, None, None, note="nothing to fit") for c in remaining if c not in screened}
    ranked = sorted(screened, key=lambda c: screened[c].criteria.min())
    # in full: the best screened few, and every cause whose first-pass fit beats the current model's
    ((_, current_read),) = fitter.fast([current.hypothesis])
    chosen = ranked[:CAUSES_FITTED_IN_FULL] + [c for c in ranked if screened[c].criteria.min() < current_read]
    chosen += [c for c in SCREEN_BLIND if c in screened]
    chosen = list(dict.fromkeys(chosen))[:MAX_FULL_CAUSES]
    # every chosen cause's full fits at once (on the fitter's threads), each cause's model from its own
    values = {c: full_values(fitter, screened[c]) for c in chosen}
    tasks = [APPLY[c](current.hypothesis, v) for c in chosen for v in values[c]]
    fitted = iter(fitter.fulls(tasks, current.fit))
    models = {c: best_of_full(fitter, screened[c], current, [(v, *next(fitted)) for v in values[c]]) for c in chosen}
    # the current model at its best: a cause must not get the credit for a better valve fit its search found
    reference = min([current.criterion, *(baseline(fitter, current, m).criterion for m in models.values())])
    for c in ranked:
        if c in models:
            m = models[c]
            params = {k: v for k, v in cause_parameters(m).items() if k in _params_of(c)}
            se = {"gain_ratio": float(m.fit.gain_se)} if "gain_ratio" in params else {}
            tried[c] = Candidate(c, params, m.error_pct(record), m.criterion, m.criterion - reference, se=se)
        else:
            sc = screened[c]
            i = int(np.argmin(sc.criteria))
            hyp = APPLY[c](current.hypothesis, float(sc.grid[i]))
            m = Model(hyp, sc.fits[i], float(sc.criteria[i]), (*current.causes, *names(c)))
            params = {k: v for k, v in cause_parameters(m).items() if k in _params_of(c)}
            tried[c] = Candidate(
                c, params, m.error_pct(record), None, None, note="screened out: first-pass fit far behind the best"
            )
    if not models:
        return tried, current
    winner = min(models, key=lambda c: models[c].criterion)
    if reference - models[winner].criterion > MARGIN:
        models[winner] = refined(fitter, models[winner], winner, current)
        m = models[winner]
        params = {k: v for k, v in cause_parameters(m).items() if k in _params_of(winner)}
        tried[winner] = Candidate(
            winner, params, m.error_pct(record), m.criterion, m.criterion - reference, accepted=True
        )
        # the rivals the data cannot rule out (other causes, and none) widen the friction's uncertainty
        rivals = spread(record, [(current.fit, current.criterion)] + [(m.fit, m.criterion) for m in models.values()])
        return tried, replace(models[winner], spread=combined(models[winner].spread, rivals))
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
        named = set(names(accepted[0]))
        remaining = [m for m in remaining if not named & set(names(m))]
    q = lattice.quantum(record.pv_pct)
    qm = quantised(record, current, q) if q is not None else None
    if qm is not None:  # the values sit on the lattice: named whatever it explains (its gain says how much)
        if not steps:
            steps.append({})
        steps[-1]["quantization"] = Candidate(
            "quantization",
            {"quantum_pct": q},
            qm.error_pct(record),
            qm.criterion,
            qm.criterion - current.criterion,
            accepted=True,
        )
        current = qm
    return current, steps


def diagnose(record: Record, max_causes: int = MAX_CAUSES, threads: int = 1) -> Diagnosis:
    """Forward selection over the catalogue from the canonical loop (see the module's docstring).

    Twice: with the sticky valve and with a valve that follows OP (no stiction).  A loop whose
    valve does not stick is no canonical loop either, and its process must still be read; the
    better of the two by the criterion is the diagnosis, and their difference says whether
    stiction earns its place.  ``threads``: the fits that do not depend on each other run on that many threads
    (``ident.cause_fit.Fitter``); the diagnosis is the same.
    """
    with Fitter(record, threads) as fitter:
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
    loaded = slow_load.named(record, chosen, steps[-1].get("external_oscillation") if steps else None)
    if loaded is not None:  # a slow load, turned down over one sample, earned its place over several
        chosen, steps = loaded[0], [*steps, {"external_oscillation": loaded[1]}]
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
        note = "PV sits on no lattice" if q is None else f"PV is stored in steps of {q:.3g} %: nothing left to explain"
        candidates["quantization"] = Candidate(
            "quantization", {} if q is None else {"quantum_pct": q}, None, None, None, note=note
        )
    fitted = widened(friction(chosen.fit, record), chosen.spread)
    lag_sd = lag_s_sd_pct(chosen, record) if np.isfinite(fitted.s_pct) else 0.0
    read = lag_widened(fitted, lag_sd)  # the deadband's trade is with fd as fitted, not along the lag's line
    played = [] if chosen.hypothesis.linear_valve else deadband_tie(fitted) + lag_band_tie(chosen, record, read)
    return Diagnosis(
        base, chosen, candidates, steps, friction(base.fit, record), read, stiction_delta,
        ties=ties(steps, chosen, record) + played, lag_s_sd_pct=lag_sd,
    )  # fmt: skip


DEADBAND_WIDENS_PCT = PCT_OF_500LBF_PER_PCT_OF_SPAN / 2
"""A deadband of width d (% of OP) in front of a sticky valve makes fs and fd each this much higher per % of
it (% of 500 lbf): S is d wider and J stays (``tests/ident/test_diagnose.py`` shows it exact)."""


def deadband_tie(read: Friction) -> list[Tie]:
    """A sticky valve's reading holds any deadband in front of it: the band read could be a narrower band
    behind play of up to S - J (fd down to zero), two standard errors of fd included.  PV is the same to the
    last digit either way, so the tie's criterion difference is 0.  A valve read at fd = 0 with no error
    leaves no room for play, and nothing is said."""
    if not (np.isfinite(read.fd_pct) and np.isfinite(read.s_pct)):
        return []
    fd_se = read.fd_se_pct if np.isfinite(read.fd_se_pct) else 0.0
    widest = (read.fd_pct + 2 * fd_se) / DEADBAND_WIDENS_PCT
    if not widest > 0:
        return []
    return [
        Tie(
            "none",
            "deadband",
            0.0,
            {"deadband_pct_high": widest},
            f"a deadband of up to {widest:.3g} % of OP in front of a valve with a narrower band explains PV exactly "
            f"as well: S includes any deadband, J not (fs and fd each {DEADBAND_WIDENS_PCT:.3g} % of 500 lbf "
            "lower per % of it)",
        )
    ]


HELD_SAMPLES_MIN = 10
"""Samples with the model's stem held that a stuck phase's OP ramp is read from."""


def lag_slope(chosen: Model, record: Record) -> float | None:
    """How much S a second of actuator lag moves (% of span a second: twice OP's median step while the model's stem
    is held, over the sample time; ``lag_band_tie``), or None where no actuator lag is named with a sticky valve."""
    if chosen.hypothesis.linear_valve or not chosen.hypothesis.actuator_tau_s > 0:
        return None
    stem = stem_path(chosen.fit, record)
    held = np.abs(np.diff(stem)) <= 1e-9 * max(1.0, float(np.max(np.abs(stem))))
    if held.sum() < HELD_SAMPLES_MIN:
        return None
    slope = 2 * float(np.median(np.abs(np.diff(record.op_pct))[held])) / record.ts_s
    return slope if slope > 0 else None


def lag_band_tie(chosen: Model, record: Record, read: Friction) -> list[Tie]:
    """Where an actuator lag is named with a sticky valve: the line along which the lag and the band trade.

    While the stem is stuck OP ramps at some rate r (% a second), and during a ramp a first-order lag is a delay
    of tau.  A model whose lag is tau' < tau reads the drive r (tau - tau') ahead of the true one, and to break the
    stem where it broke and land it where it landed it needs a band and a stop each that much wider: S (band +
    stop) reads 2 r (tau - tau') wider, J (band - stop) the same.  In a limit cycle, whose ramps are alike, the
    criterion hardly tells the lags apart (fits at lags of 2-8 s lie within a few units, their fs 15-20 % of 500
    lbf apart: docs/benchmarks.md), so the report gives the line, S at no lag and its slope 2 r (r the median of
    OP's steps while the model's stem is held), which a stroke test's lag reads S off.  On the 24 actuator lags of
    the wide draws at the bench's seed, 4242 and 9001, S read was 0.6-27 % of span off (median 2.7); on the line at
    the true lag, 0.06-2.9 % on 23 (median 0.8), and 23 off on a lag of 8.5 s read 0.7 s beside a dead time.  On
    seeds 31 and 6161, judged after: 0.14-3.1 % off on the 12 without a dead time named beside the lag, 0.6, 16 and
    17 on the 3 with one (a second delay shares the lag's): the note says so there."""
    tau = chosen.hypothesis.actuator_tau_s
    slope = lag_slope(chosen, record)
    if slope is None or not np.isfinite(read.s_pct):
        return []
    s0 = read.s_pct + slope * tau
    rougher = (
        "; with a dead time named beside the lag, which delays as it does, the line is a rougher guide"
        if chosen.hypothesis.dynamics.dead_time_s > 0
        else ""
    )
    return [
        Tie(
            "actuator_lag",
            "actuator_lag",
            None,
            {"s_pct_at_no_lag": s0, "s_pct_per_lag_s": slope},
            f"a slower actuator or a wider band: each second of actuator lag reads as {slope:.3g} % less S (OP ramps "
            f"{slope / 2:.3g} % a second while the valve sticks, and band and stop each follow it; J is the same), "
            f"and a limit cycle hardly tells them apart: S {read.s_pct:.3g} % at the lag read ({tau:.3g} s) is "
            f"about {s0:.3g} - {slope:.3g} x lag (s) at another, which a stroke test's lag reads S off{rougher}",
        )
    ]


RANGE_SDS = 2.0
"""Standard deviations either side that a named parameter's range (``ident.models.RANGE_LOG``, about 95 %) spans."""


def lag_s_sd_pct(chosen: Model, record: Record) -> float:
    """S's standard deviation from the actuator lag's doubt (``lag_widened``), % of span; 0 where no lag is named
    with a sticky valve."""
    slope = lag_slope(chosen, record)
    if slope is None:
        return 0.0
    return slope * chosen.hypothesis.actuator_tau_s * RANGE_LOG["actuator_tau_s"] / RANGE_SDS


def lag_widened(read: Friction, s_sd_pct: float) -> Friction:
    """``read`` with the actuator lag's own uncertainty carried along the line on which lag and band trade
    (``lag_band_tie``): ``s_sd_pct`` (``lag_s_sd_pct``: the lag's standard deviation, its range's log half-width
    over ``RANGE_SDS`` times the lag, times the line's slope) added in quadrature to S's error, and half of it (in %
    of 500 lbf) to fs's and fd's (band and stop each move half of S); J does not move along the line.

    The errors of a fit at one lag do not see the lag's doubt: on the 8 actuator lags of seed 9191's wide draws
    (``stiction bench diagnose``), lags read 0.4-2.1 times the truth, S read within two of its errors held the
    truth on 3 of 8, the worst 5.6 errors off (a lag of 4.0 s read 8.1 s, S 10.4 % read against 22)."""
    if not (s_sd_pct > 0 and np.isfinite(read.s_pct)):
        return read
    side = PCT_OF_500LBF_PER_PCT_OF_SPAN * s_sd_pct / 2
    return replace(
        read,
        s_se_pct=float(np.hypot(read.s_se_pct, s_sd_pct)),
        fs_se_pct=float(np.hypot(read.fs_se_pct, side)),
        fd_se_pct=float(np.hypot(read.fd_se_pct, side)),
    )


GAIN_SE_COVER = 2.0
"""Standard errors either side of a turned-down gain's fit that the data allow (about 95 %)."""


def _interval_text(lo: float, hi: float) -> str:
    """``lo-hi`` with the digits that tell the two ends apart (a tight interval about 1 read "1-1")."""
    digits = 3 if hi - lo <= 0 else max(3, int(np.ceil(-np.log10((hi - lo) / max(abs(hi), 1e-300)))) + 1)
    return f"{lo:.{digits}g}-{hi:.{digits}g}"


def _gain_interval(cand: Candidate | None) -> list[Tie]:
    """A process gain turned down whose interval (``GAIN_SE_COVER`` standard errors) holds the nominal:
    the data allow any gain in it, and the report gives the interval rather than "nominal"."""
    if cand is None or cand.accepted or "gain_ratio" not in cand.parameters or "gain_ratio" not in cand.se:
        return []
    ratio, se = cand.parameters["gain_ratio"], cand.se["gain_ratio"]
    lo, hi = ratio - GAIN_SE_COVER * se, ratio + GAIN_SE_COVER * se
    if not (np.isfinite(lo) and np.isfinite(hi) and lo <= 1.0 <= hi):
        return []
    return [
        Tie(
            "none",
            "process_gain",
            cand.delta_criterion,
            {"gain_ratio_low": lo, "gain_ratio_high": hi},
            f"a process gain of {_interval_text(lo, hi)} times the nominal explains PV as well (two standard errors)",
        )
    ]


def ties(steps: list[dict[str, Candidate]], chosen: Model, record: Record) -> list[Tie]:
    """The answers the data cannot tell from the one given, step by step of the forward selection:
    a cause accepted by less than ``TIE_CRITERION`` (it, or nothing more); a rival whose fit came
    within that of the accepted cause's; a cause turned down by no more than that; a process gain turned
    down whose interval holds the nominal (``_gain_interval``).  And where the
    process reads as integrating, the lag beyond which the record may not tell a self-regulating
    process from it (``ident.cause_fit.told_lag_s``).  Quantisation is read from the values'
    lattice, not weighed, and ties with nothing."""
    out: list[Tie] = []
    for step in steps:
        fitted = {c: k for c, k in step.items() if k.criterion is not None and c != "quantization"}
        accepted = [k for k in fitted.values() if k.accepted]
        if not accepted:
            gain = _gain_interval(fitted.get("process_gain"))  # says more than a tie of the criteria
            out += gain + [
                Tie("none", c, k.delta_criterion, k.parameters, "turned down by less than the tie")
                for c, k in fitted.items()
                if k.delta_criterion is not None and k.delta_criterion <= TIE_CRITERION
                and not (gain and c == "process_gain")
            ]
            continue
        won = accepted[0]
        if won.delta_criterion is not None and -won.delta_criterion <= TIE_CRITERION:
            out.append(Tie(won.cause, "none", -won.delta_criterion, {}, "accepted by less than the tie"))
        out += [
            Tie(won.cause, c, k.criterion - won.criterion, k.parameters, "a rival fit as good")
            for c, k in fitted.items()
            if c != won.cause and k.criterion - won.criterion <= TIE_CRITERION
        ]
    if chosen.hypothesis.dynamics.time_constant_s is None:
        told = told_lag_s(record)
        out.append(
            Tie(
                "none",
                "process_type",
                None,
                {"time_constant_s_low": told},
                f"a self-regulating process with a lag of {told:.4g} s or longer: this "
                f"{record.n * record.ts_s:.4g} s record does not always tell it from integrating",
            )
        )
    return out


def _params_of(move: str) -> tuple[str, ...]:
    from stiction.sim.extensions import CATALOGUE

    return tuple(p for c in names(move) for p in CATALOGUE[c])


def _first_look(steps: list[dict[str, Candidate]]) -> dict[str, Candidate]:
    """Each cause as last tried (its latest step), accepted or not."""
    out: dict[str, Candidate] = {}
    for step in steps:
        out.update(step)
    return out
