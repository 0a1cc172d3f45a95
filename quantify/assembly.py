"""A report's assembly, in one place: the window's facts, then what is known of the loop's process.

The pipeline turns a window into a *draft*: a ``StictionReport`` with every field the window
shows (verdict, evidence, the method's numbers, the warnings about the window) and no word on
the process yet where it is neither declared nor identified as the thesis's.  ``assemble`` makes
the report from a draft and what is known beside it: the process identified from the window
(``ident.sizing``: by ``stiction quantify`` at once, by the agent in the background), the export's
warnings, the agent's id, a measured stem's valve check.  Every warning is added here once, where its fact is known,
and none is taken back but the window's "no friction numbers", where a measured stem gives them: a draft assembled
again with a newer sizing gives the newer report.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from stiction.ident.sizing import Sizing
from stiction.ident.trust import explains_none
from stiction.quantify.window import Window
from stiction.schemas.report import Estimate, ProcessInfo, StictionReport
from stiction.sim.process import LOOPS
from stiction.sim.valve import band_and_jump_pct, band_and_jump_se_pct, fault_kind, friction_pct, friction_se_pct

NOT_IDENTIFIED = (
    "process neither declared nor identified: the physical reading of the slips (which needs the thesis's level "
    "loop) is not used"
)
"""Said of a loop called sticky only: a loop with no valve fault has no friction to read, whatever its process."""
NOT_READ_WARNING = (
    "S and J not read: the learned models know only the thesis's level loop and this loop's process is "
    "neither declared nor identified (their readings stay in the 'learned' and 'thesis' blocks); "
    "stiction quantify and stiction diagnose read S and J under the process they identify, the agent "
    "in the background (--size-every)"
)
NOT_READ_PREFIX = "S and J not read under the identified process: "
NOTHING_SHOWN = {"thesis": None, "physical": None, "learned": None}
NO_NUMBERS = "no friction numbers: "
"""How the pipeline's warning that a verdict other than stiction gives no numbers begins (``quantify.pipeline``)."""


def opt(x) -> float | None:
    """A finite number, or None (the report's null)."""
    x = float(x)
    return x if math.isfinite(x) else None


def estimate_block(values) -> Estimate:
    if values is None:
        return Estimate(fs_pct=None, fd_pct=None)
    fs, fd, fs_se, fd_se = values
    return Estimate(fs_pct=opt(fs), fd_pct=opt(fd), fs_se_pct=opt(fs_se), fd_se_pct=opt(fd_se))


PROCESS_RANGES = ("time_constant_s", "dead_time_s", "sensor_tau_s", "actuator_tau_s")
"""The diagnosis's ranges a report's ``process`` carries: those of its own fields."""


def process_info(w: Window, ts_s: float, identified: bool) -> ProcessInfo:
    """The thesis's level loop where declared or recognised (``quantify.policy.canonical_level``), else unknown."""
    if w.process == "level" or identified:
        source = "declared" if w.process == "level" else "identified"
        return ProcessInfo(kind="integrating", source=source, gain=LOOPS["level"].gain, sample_time_s=ts_s)
    return ProcessInfo(kind="unknown", source="none", sample_time_s=ts_s)


def friction_fields(method: str, estimate: Sequence[float], t_end_s: float | None) -> dict:
    """The headline numbers of the method that speaks: fs, fd and their S, J, in the report's fields."""
    fs, fd, fs_se, fd_se = (opt(v) for v in estimate)
    s_pct = j_pct = s_se = j_se = None
    if fs is not None and fd is not None:
        s_pct, j_pct = (opt(v) for v in band_and_jump_pct(fs, fd))
        if fs_se is not None:
            s_se, j_se = (opt(v) for v in band_and_jump_se_pct(fs_se, fd_se or 0.0))
    return {
        "method": method, "fs_pct": fs, "fd_pct": fd, "fs_se_pct": fs_se, "fd_se_pct": fd_se,
        "s_pct": s_pct, "j_pct": j_pct, "s_se_pct": s_se, "j_se_pct": j_se,
        "stiction_kind": fault_kind(s_pct, j_pct, j_se),
        "estimate_t_end_s": t_end_s if method != "none" else None,
    }  # fmt: skip


def needs_sizing(report: StictionReport) -> bool:
    """Whether a sizing under an identified process would change the report of this draft: a loop
    called sticky whose process is neither declared nor identified as the thesis's."""
    return report.verdict == "stiction" and report.process.source == "none"


def identified_warning(sizing: Sizing) -> str:
    head = f"process identified from OP and PV (stiction diagnose): {sizing.process.description}"
    none_explained = explains_none(sizing.process)
    if none_explained:
        head += "; it " + none_explained
    if not sizing.read:
        return head
    return head + "; S and J are read under it, their uncertainty including the model error measured on simulated " \
        "plant-like loops"  # fmt: skip


def stem_fields(check, t_end_s: float | None) -> dict:
    """The report's verdict and numbers read from a measured stem that sticks (``quantify.stem``) in the window that
    ended at ``t_end_s``."""
    s, j, s_se, j_se = (opt(v) for v in (check.s_pct, check.j_pct, check.s_se_pct, check.j_se_pct))
    fs, fd = (opt(v) for v in friction_pct(s, j))
    fs_se, fd_se = (opt(v) for v in friction_se_pct(s_se, j_se))
    return {
        "verdict": "stiction", "likely_cause": "stiction", "method": "stem",
        "s_pct": s, "j_pct": j, "s_se_pct": s_se, "j_se_pct": j_se, "stiction_kind": fault_kind(s, j, j_se),
        "fs_pct": fs, "fd_pct": fd, "fs_se_pct": fs_se, "fd_se_pct": fd_se, "estimate_t_end_s": t_end_s,
    }  # fmt: skip


def stem_warning(check, draft: StictionReport) -> str:
    """What the measured stem showed, against what OP and PV alone said."""
    valve = "Choudhury's two-parameter" if check.valve == "two_parameter" else "the thesis's physical"
    lag = f"an actuator lag of {check.actuator_tau_s:.2g} s"
    if check.sticky:
        alone = (
            ""
            if draft.verdict == "stiction"
            else f"; OP and PV alone said {draft.verdict.replace('_', ' ')} (stiction probability "
            f"{draft.stiction_probability:.2f}): the stem itself says stiction, and S and J are read from it"
        )
        return (
            f"the measured stem (mv) sticks: {valve} valve with {lag} fits it better than a linear one by "
            f"{check.delta_criterion:.0f} of Schwarz's criterion{alone}"
        )
    said = (
        ", against the verdict from OP and PV: if mv is the stem's measured travel, the cycle has another cause; "
        "if it is the positioner's demand (OP again), it says nothing of the valve"
        if draft.verdict == "stiction"
        else ""
    )
    return f"the measured stem (mv) follows OP: a linear valve with {lag} fits it best{said}"


def _stem_against_loop(check, draft: StictionReport, update: dict) -> str:
    """The stem's S beside the loop's (``update`` over ``draft``), and which of the two the report shows."""
    s, s_se = update.get("s_pct", draft.s_pct), update.get("s_se_pct", draft.s_se_pct)
    if s is None or s_se is None:
        return f"the stem reads S {check.s_pct:.3g} +- {check.s_se_pct:.2g} %, which the report shows"
    agree = abs(s - check.s_pct) <= 2 * float(np.hypot(s_se, check.s_se_pct))
    shown = "the stem's" if check.s_se_pct < s_se else "the loop's, the surer"
    return (
        f"the stem reads S {check.s_pct:.3g} +- {check.s_se_pct:.2g} %, the loop {s:.3g} +- {s_se:.2g} %: "
        f"{'they agree' if agree else 'they differ by more than two errors'}; the report shows {shown}"
    )


def assemble(
    draft: StictionReport,
    sizing: Sizing | None = None,
    sizing_t_end_s: float | None = None,
    note: str | None = None,
    notes: Sequence[str] = (),
    agent_id: str | None = None,
    stem=None,
    stem_note: str | None = None,
) -> StictionReport:
    """The report of ``draft`` (``quantify.pipeline``'s, for one window) with what is known beside it.

    ``sizing``: the process identified from the loop's window and S, J read under it, used where
    ``needs_sizing(draft)`` (a sticky loop of unknown process); ``sizing_t_end_s``: the end of the
    window it was made from; ``note``: a warning added where its numbers are shown (the agent's
    re-read); ``notes``: warnings of the record itself (an export's); ``agent_id``: the agent's.
    ``stem``: the valve check of the window's measured stem (``quantify.stem``): where it sticks, the verdict and
    S and J are its; ``stem_note``: why a recorded stem was not read."""
    head, tail, update = [], [], {}
    kept = list(draft.warnings)
    read_stem = stem is not None and draft.verdict != "bad_data"
    from_stem = read_stem and stem.sticky and draft.verdict != "stiction"
    if from_stem:  # the window's "no friction numbers" gives way to the stem's verdict and numbers
        update |= stem_fields(stem, draft.t_end_s)
        kept = [w for w in kept if not w.startswith(NO_NUMBERS)]
    unknown = draft.process.source == "none"
    sized = sizing is not None and needs_sizing(draft)
    identified = sized and sizing.process is not None
    if unknown and not identified and draft.verdict == "stiction":
        head.append(NOT_IDENTIFIED)
        tail.append(NOT_READ_WARNING)
    if sized and not identified:  # the identification itself failed: say why
        tail.append(NOT_READ_PREFIX + sizing.why)
    if identified:
        p = sizing.process
        head.append(identified_warning(sizing))
        update["process"] = ProcessInfo(
            kind=p.kind, source="identified", gain=p.gain, gain_se=p.gain_se, time_constant_s=p.time_constant_s,
            dead_time_s=p.dead_time_s, sensor_tau_s=p.sensor_tau_s, actuator_tau_s=p.actuator_tau_s,
            sample_time_s=draft.process.sample_time_s, description=p.description,
            pv_explained_share=p.pv_explained_share,
            parameter_ranges={k: v for k, v in sizing.parameter_ranges.items() if k in PROCESS_RANGES},
        )  # fmt: skip
        if not sizing.read:
            tail.append(NOT_READ_PREFIX + sizing.why)
        else:
            s, j, s_se, j_se = (opt(v) for v in (sizing.s_pct, sizing.j_pct, sizing.s_se_pct, sizing.j_se_pct))
            fs, fd, fs_se, fd_se = (opt(v) for v in sizing.fs_fd_pct())
            update |= {
                "method": "identified", "s_pct": s, "j_pct": j, "s_se_pct": s_se, "j_se_pct": j_se,
                "stiction_kind": fault_kind(s, j, j_se),
                "fs_pct": fs, "fd_pct": fd, "fs_se_pct": fs_se, "fd_se_pct": fd_se,
                "estimate_t_end_s": sizing_t_end_s,
            }  # fmt: skip
            tail.extend(sizing.doubts)
            if note:
                tail.append(note)
    if read_stem:
        tail.append(stem_warning(stem, draft))
        if stem.sticky and not from_stem:  # called sticky from OP and PV too: the surer reading speaks
            tail.append(_stem_against_loop(stem, draft, update))
            loop_se = update.get("s_se_pct", draft.s_se_pct)
            if loop_se is None or stem.s_se_pct < loop_se:
                update |= stem_fields(stem, draft.t_end_s)
                # the stem's numbers are shown: the loop's "not read" no longer holds
                head = [w for w in head if w != NOT_IDENTIFIED]
                tail = [w for w in tail if w != NOT_READ_WARNING]
    if stem_note:
        tail.append(stem_note)
    tail.extend(notes)
    if head or tail or len(kept) != len(draft.warnings):
        update["warnings"] = [*head, *kept, *tail]
    if agent_id is not None:
        update["agent_id"] = agent_id
    return draft.model_copy(update=update) if update else draft


def with_model(details, sizing: Sizing | None):
    """``quantify.pipeline.Details`` (or None) with the identified model's PV, where ``sizing`` carries it."""
    if details is None or sizing is None or sizing.model_pv_pct is None:
        return details
    return dataclasses.replace(details, model_pv=sizing.model_pv_pct)
