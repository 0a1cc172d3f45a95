"""What the data cannot tell apart, beside the diagnosis they give (``Diagnosis.ties``): a deadband in front of a
sticky valve against a wider band, an actuator's lag against the band (a line, and the doubt it puts on S), a
process gain turned down whose interval holds the nominal, a cause accepted or turned down by less than
``TIE_CRITERION``, and a self-regulating lag longer than the record tells from integrating.  Read from the
forward selection's steps (``ident.diagnose``) and the chosen model; no fit of their own."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from stiction.ident.cause_fit import told_lag_s
from stiction.ident.friction import Friction, stem_path
from stiction.ident.models import RANGE_LOG, TIE_CRITERION, Candidate, Model, Tie
from stiction.ident.record import Record
from stiction.sim.valve import PCT_OF_500LBF_PER_PCT_OF_SPAN

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


def lag_band_tie(chosen: Model, read: Friction, slope: float | None) -> list[Tie]:
    """Where an actuator lag is named with a sticky valve (``slope``, its ``lag_slope``, not None): the line along
    which the lag and the band trade.

    While the stem is stuck OP ramps at some rate r (% a second), and during a ramp a first-order lag is a delay
    of tau.  A model whose lag is tau' < tau reads the drive r (tau - tau') ahead of the true one, and to break the
    stem where it broke and land it where it landed it needs a band and a stop each that much wider: S (band +
    stop) reads 2 r (tau - tau') wider, J (band - stop) the same.  Where the stem slides along the drive
    (``ident.fit.walk``, since 2026-11-27) the slides pin the stop and J moves with the band: ``lag_widened`` widens
    J's error too.  In a limit cycle, whose ramps are alike, the
    criterion hardly tells the lags apart (fits at lags of 2-8 s lie within a few units, their fs 15-20 % of 500
    lbf apart: docs/benchmarks.md), so the report gives the line, S at no lag and its slope 2 r (r the median of
    OP's steps while the model's stem is held), which a stroke test's lag reads S off.  On the 24 actuator lags of
    the wide draws at the bench's seed, 4242 and 9001, S read was 0.6-27 % of span off (median 2.7); on the line at
    the true lag, 0.06-2.9 % on 23 (median 0.8), and 23 off on a lag of 8.5 s read 0.7 s beside a dead time.  On
    seeds 31 and 6161, judged after: 0.14-3.1 % off on the 12 without a dead time named beside the lag, 0.6, 16 and
    17 on the 3 with one (a second delay shares the lag's): the note says so there."""
    tau = chosen.hypothesis.actuator_tau_s
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
            f"{slope / 2:.3g} % a second while the valve sticks, and band and stop each follow it between slips; "
            f"where the stem slides along the lagged drive the stop is pinned and J moves too), "
            f"and a limit cycle hardly tells them apart: S {read.s_pct:.3g} % at the lag read ({tau:.3g} s) is "
            f"about {s0:.3g} - {slope:.3g} x lag (s) at another, which a stroke test's lag reads S off{rougher}",
        )
    ]


RANGE_SDS = 2.0
"""Standard deviations either side that a named parameter's range (``ident.models.RANGE_LOG``, about 95 %) spans."""


def lag_s_sd_pct(chosen: Model, slope: float | None) -> float:
    """S's standard deviation from the actuator lag's doubt (``lag_widened``), % of span, from the line's ``slope``
    (``lag_slope``); 0 where no lag is named with a sticky valve (``slope`` None)."""
    if slope is None:
        return 0.0
    return slope * chosen.hypothesis.actuator_tau_s * RANGE_LOG["actuator_tau_s"] / RANGE_SDS


def lag_widened(read: Friction, s_sd_pct: float) -> Friction:
    """``read`` with the actuator lag's own uncertainty carried along the line on which lag and band trade
    (``lag_band_tie``): ``s_sd_pct`` (``lag_s_sd_pct``: the lag's standard deviation, its range's log half-width
    over ``RANGE_SDS`` times the lag, times the line's slope) added in quadrature to S's error, all of it to J's, all
    of it (in % of 500 lbf) to fs's and half to fd's.  While the fit's stem jumped from landing to landing behind a
    lagged drive, band and stop each moved half of S and J stood still; since it slides along the drive (the
    spec's valve, 2026-11-27) the slides pin the stop and the band's breaks carry the lag's doubt (on the lag loop
    of ``tests/ident/test_diagnose.py`` the band read 0.35 % short, the stop 0.08 % long): J moves with S.

    The errors of a fit at one lag do not see the lag's doubt: on the 8 actuator lags of seed 9191's wide draws
    (``stiction bench diagnose``), lags read 0.4-2.1 times the truth, S read within two of its errors held the
    truth on 3 of 8, the worst 5.6 errors off (a lag of 4.0 s read 8.1 s, S 10.4 % read against 22); with this, 8 of 8.
    Nothing tuned (the range was calibrated on seeds 777-782); judged on seeds 8383 and 4747: 14 -> 15 of 16, S's
    error in median 2.9 and 2.3 times what it was (docs/benchmarks.md)."""
    if not (s_sd_pct > 0 and np.isfinite(read.s_pct)):
        return read
    side = PCT_OF_500LBF_PER_PCT_OF_SPAN * s_sd_pct
    return replace(
        read,
        s_se_pct=float(np.hypot(read.s_se_pct, s_sd_pct)),
        j_se_pct=float(np.hypot(read.j_se_pct, s_sd_pct)),
        fs_se_pct=float(np.hypot(read.fs_se_pct, side)),
        fd_se_pct=float(np.hypot(read.fd_se_pct, side / 2)),
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
