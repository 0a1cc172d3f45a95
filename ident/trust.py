"""What a fitted valve's friction numbers are worth: the model error added to the fit's own standard
errors, the stuck-travel check that withholds a band the record contradicts, and the doubts a report
states beside a band it gives (``band_doubts``).

Below both ``ident.report`` (which applies them to every diagnosis) and ``ident.sizing`` (which
reads a diagnosis's S and J), so that neither imports the other; the figures behind the
constants are in ``ident.sizing``'s description.
"""

from __future__ import annotations

import math
from dataclasses import replace

from stiction.sim.valve import PCT_OF_500LBF_PER_PCT_OF_SPAN, friction_se_pct

MODEL_ERROR_S = 0.20
"""Standard error of S from the model's mismatch, as a share of S (seeds 2026, 2027 of ``sim.plant_loops``)."""
MODEL_ERROR_J = 0.30
"""Standard error of J from the model's mismatch, as a share of S."""
STUCK_TRAVEL_SHARE = 0.5
"""S + 2 se must reach this share of the stuck OP travel (``detect.features``).  A valve stuck
while OP moves by d has S >= d (it moves once OP is S past the stuck position on a reversal, J
in the same direction, J <= S); the half allows for PV's noise hiding a small move.  On the 40
sticky loops of seed 2030 called sticky, the travel was at most 1.3 times the true S and every
band read passed; on a measured flow loop (OP up 0.42 % in steps while PV stood still, then a
slip) it withholds S 0.03 +- 0.01 % from a model whose PV missed the record entirely.  The
travel over a stuck setpoint step's still phase (``detect.setpoint``) counts too: on 52 simulated
sticky loops with such a step (seeds 2030-2032) it was 0.41-1.89 times the true S."""


def stuck_travel_contradicts(s_pct: float, s_se_pct: float, travel_pct: float) -> str | None:
    """Why a band is withheld where S + 2 se is below ``STUCK_TRAVEL_SHARE`` of the OP travel over
    which PV stood still (``travel_pct``, % of span, ``detect.features.stuck_travel``; 0 where
    none was seen), else None."""
    if not (travel_pct > 0 and math.isfinite(s_pct)) or s_pct + 2 * s_se_pct >= STUCK_TRAVEL_SHARE * travel_pct:
        return None
    return (
        f"the fit reads S {s_pct:.2g} +- {s_se_pct:.2g} % of span, but OP moved {travel_pct:.2g} % in a straight "
        "line while PV stood still, and a valve that stays put through that has a band of about that at least: "
        "the identified model does not describe this loop, its friction numbers are withheld"
    )


def without_uncertainty(f) -> str | None:
    """Why a band the fit reads cannot be given, or None: S, or a J given, without a standard error (a parameter
    held at its bound, as fd at zero with the whole band read as jump, has none; ``band_bound`` says why there).
    Every number a report gives has one; ``ident.sizing`` turns such a reading down the same way."""
    if not math.isfinite(f.s_pct) or (math.isfinite(f.s_se_pct) and (math.isfinite(f.j_se_pct)
                                                                       or not math.isfinite(f.j_pct))):  # fmt: skip
        return None
    return (
        f"the fit reads S {f.s_pct:.3g} % and J {f.j_pct:.3g} % of span with no standard error (a parameter held at "
        "its bound, as fd at zero with the whole band read as jump): S and J are not separable from the process "
        "gain in this record, and its friction numbers are withheld"
    )


DRAGGED_SHARE = 0.5
"""A model valve that moves at this share of the samples or more does not stick: it moves more often than it stays."""


def dragged(slips_read: int, slips: int, samples: int) -> str | None:
    """Why a band is withheld where no slip of the stem shows in PV (none the fit keeps from the data's segmentation)
    and the model's valve moves at ``DRAGGED_SHARE`` of the samples or more, else None.  S is the OP travel after a
    reversal before the stem moves: a valve that moves at most samples has no stuck phase to read it from, and its
    band is whatever width lets the model's stem, dragged behind OP, match PV's phase, which a dead time or a lag of
    the process gives as well.  On the independent simulator's sticky loops (``sim.two_parameter``: Choudhury's
    valve, backlash and small slips) bands so read were 0.06 +- 0.02 for 1.19 and 4.05 +- 0.95 for 7.55 (seeds 4321
    and 8585), with a dead time read 2-4 times the true one; on measured windows, level and flow loops whose model
    valve moved at 750 of 751 samples (2111LIC31102B, labelled healthy)."""
    if slips_read > 0 or slips < DRAGGED_SHARE * samples:
        return None
    return (
        f"no slip of the stem shows in PV, and the model's valve moves at {slips} of {samples} samples: a valve "
        "dragged behind OP, not one that sticks between slips; its band is the width that matches PV's phase, which "
        "a dead time or lag of the process gives as well, and its friction numbers are withheld"
    )


def band_bound(f) -> str | None:
    """Where the fit holds the stop at its bound (fd at zero: S = J = the static band b, J with no standard error),
    why its numbers are withheld, with the least band the slips allow; None otherwise.

    A valve that has slipped sticks again, and on its way on in the same direction slips after J of OP's travel; only
    after a reversal does it wait for the whole band S.  A model whose stop is held at zero slips the whole band
    each time, so the slips' timing reads their spacing: J in a record of long runs one way, S in a limit cycle.  On
    the independent simulator's sticky loops, limit cycles mostly (``sim.two_parameter``, seed 2030: 9 of 41 held
    so), S so read was 17 % off in median and within two errors on 8 of 9; on the plant-like families of
    ``sim.plant_families`` (setpoint steps, loads, detuned controllers, backlash; seeds 4242 and 4243, 12 of 86 S
    read), it was below the true S on 11 of 12 and within two errors on 7 (5.11 % read 0.58 +- 0.15, 33.6 read
    19.8 +- 4.6), where the fit's other readings were within on 95 % of the windows showing the fault.  So S is
    not given there (it was from 2026-11-27 to 2026-11-29); the read less two of its errors (the band's, with the
    stop held, and the model error), a bound that held on all 12, is said as the least band the slips allow.  Judged
    on seeds never used before (2026-11-29): the families' seed 7171, 2 of 6 S read so within two errors, the bound
    held on 6; ``sim.plant_loops`` seed 2036, 1 of 3, 3; the independent simulator's seed 2036, 5 of 8, 7 (one band
    of 1.11 % read 3.07 +- 0.90)."""
    if not (math.isfinite(f.s_pct) and not math.isfinite(f.s_se_pct) and math.isfinite(f.fs_se_pct)):
        return None
    if not abs(f.s_pct - f.j_pct) <= 1e-9 * max(1.0, abs(f.s_pct)):  # not the stop at its bound: another parameter
        return None
    b_se = f.fs_se_pct / PCT_OF_500LBF_PER_PCT_OF_SPAN
    least = f.s_pct - 2 * math.hypot(b_se, MODEL_ERROR_S * f.s_pct)
    bound = f"; the slips allow a band S of {least:.2g} % of span at least (the read less two errors)"
    return (
        "the fit holds the valve's stop at its bound (the whole band read as jump): its slips' timing reads their "
        "spacing, which is J where OP runs one way and S only after a reversal, and the band's split into slip and "
        f"stop is not separable from the process gain in this record: S and J are withheld{bound if least > 0 else ''}"
    )


def with_model_error(f):
    """``ident.friction.Friction`` with the model error added to its standard errors (in quadrature):
    S's by ``MODEL_ERROR_S`` S, J's by ``MODEL_ERROR_J`` S, and fs's and fd's by what those two
    make of them (``sim.valve.friction_se_pct``)."""
    if not math.isfinite(f.s_pct):
        return f
    model_s, model_j = MODEL_ERROR_S * f.s_pct, MODEL_ERROR_J * f.s_pct
    model_fs, model_fd = (float(v) for v in friction_se_pct(model_s, model_j))
    return replace(
        f,
        s_se_pct=math.hypot(f.s_se_pct, model_s),
        j_se_pct=math.hypot(f.j_se_pct, model_j),
        fs_se_pct=math.hypot(f.fs_se_pct, model_fs),
        fd_se_pct=math.hypot(f.fd_se_pct, model_fd),
    )


PLAUSIBLE_GAIN = 10.0
"""A self-regulating process gain (% of PV's span per % of travel) above which the report doubts the fit:
the valve's whole stroke would move PV ten spans, and a loop's operating range would sit within a tenth
of the travel.  The simulated plant loops draw 0.3-3; a fit that reads far more explains PV by stem moves
too small to be the valve's (a measured flow loop read 112 with a band of 2.3 %).  Physics, not tuned on
the measured windows."""


def holds_zero(s_pct: float, s_se_pct: float, j_pct: float = math.nan, j_se_pct: float = math.nan) -> bool:
    """S's interval of two standard errors holds 0: a band the data cannot tell from none (False where either is
    not a number).  A slip J whose own interval excludes 0 tells the band from none whatever S's error: a valve's
    band is at least its slip (S = J + twice the stop), so S's interval is read from J's lower end up.  S's error
    is symmetric where its doubt is not: an actuator lag's carries S along a line that ends at J
    (``ident.ties.lag_widened``)."""
    if math.isfinite(j_pct) and math.isfinite(j_se_pct) and j_pct - 2 * j_se_pct > 0:
        return False
    return math.isfinite(s_pct) and math.isfinite(s_se_pct) and s_pct - 2 * s_se_pct <= 0


def band_doubts(
    s_pct: float, s_se_pct: float, process, j_pct: float = math.nan, j_se_pct: float = math.nan
) -> list[str]:
    """What makes a band read doubtful though the fit gives it (``process``: a ``schemas.diagnosis.Process``):
    an interval of two standard errors that holds no band at all (a slip read clear of 0 is a band:
    ``holds_zero``), and a process gain no valve loop has."""
    out = []
    if holds_zero(s_pct, s_se_pct, j_pct, j_se_pct):
        out.append(
            f"the band S {s_pct:.3g} +- {s_se_pct:.2g} % of span: its interval of two standard errors holds "
            "0, a band the data cannot tell from none; not a valve job on this evidence alone"
        )
    if process is not None and process.kind == "self_regulating" and process.gain > PLAUSIBLE_GAIN:
        out.append(
            f"the fit's process gain is {process.gain:.3g} % of span per % of travel: the valve's whole stroke "
            f"would move PV {process.gain:.3g} spans; a fit that explains PV by stem moves this small reads "
            "its band under a doubtful process: read S and J with care (PV recorded in engineering units reads "
            "as such a gain: give its range with --pv-span LO HI)"
        )
    return out


def course_share(share: float | None) -> str:
    """``pv_explained_share`` (``schemas.diagnosis.Process``) in words: "explains 87 % of PV's course", or none."""
    if share is None:
        return "PV has no course to explain"
    return f"explains {100 * share:.0f} % of PV's course" if share > 0 else "explains none of PV's course"


def explains_none(process) -> str | None:
    """Why an identified process (``schemas.diagnosis.Process``) is no description of PV's course, as a clause whose
    subject is the model ("explains none of PV's course ..."), or None where its simulation from OP explains some."""
    share = process.pv_explained_share
    if share is None or share > 0:
        return None
    return (
        f"{course_share(share)} (pv_explained_share {share:.2g}): PV simulated from OP through it is further from the "
        "record than the same model with the valve held still (its offset, drift and initial state fitted); it "
        "predicts PV a sample ahead, not over the record, and the process it names is not shown to be the loop's"
    )
