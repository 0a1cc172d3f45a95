"""A report's friction read under the process identified from its own window (``ident.sizing``).

The pipeline's learned models read the thesis's level loop only; a loop called sticky whose
process is neither declared nor identified as the thesis's gets ``method: "none"`` from
them.  ``with_sizing`` (pure) puts a sizing made from the loop's window (by ``stiction
quantify`` at once, by the agent in the background: ``agent.sizing_plan``) into such a
report; ``size_safely`` makes one, a failure becoming the reason it read nothing.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os

import numpy as np

from ident.sizing import Sizing
from schemas.report import ProcessInfo, StictionReport
from sim.valve import fault_kind

NOT_IDENTIFIED = "process neither declared nor identified: the physical reading of the slips (level loop) is not used"
NOT_READ_WARNING = (
    "S and J not read: the learned models know only the thesis's level loop and this loop's process is "
    "neither declared nor identified (their readings stay in the 'learned' and 'thesis' blocks); "
    "stiction quantify and stiction diagnose read S and J under the process they identify, the agent "
    "in the background (--size-every)"
)
NOT_READ_PREFIX = "S and J not read under the identified process: "


def size_safely(op: np.ndarray, pv: np.ndarray, ts_s: float, loop_id: str, sp=None) -> Sizing:
    """``ident.sizing.size``, a failure of the identification becoming the reason nothing was read."""
    from ident.sizing import size
    from schemas.errors import StictionError

    try:
        return size(op, pv, ts_s, loop_id, sp)
    except StictionError as e:
        why = str(e)
    except Exception as e:  # noqa: BLE001 - a fit that breaks on one loop must cost that loop's numbers only
        why = f"{type(e).__name__}: {e}"
    nan = float("nan")
    return Sizing(nan, nan, nan, nan, None, 0, f"the process could not be identified ({why})")


def _opt(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def with_sizing(report: StictionReport, sizing: Sizing, t_end_s: float | None, note: str | None = None):
    """``report`` with the sizing's process, S, J, fs and fd, where the report is of a sticky loop of
    unknown process (any other report is returned as it is).  ``t_end_s``: the end of the window
    the sizing was made from; ``note``: a warning added where the numbers are shown."""
    if not needs_sizing(report):
        return report
    if sizing.process is None:  # the identification itself failed: say so, the rest stays
        return report.model_copy(update={"warnings": [*report.warnings, NOT_READ_PREFIX + sizing.why]})
    p = sizing.process
    warnings = [w for w in report.warnings if w not in (NOT_IDENTIFIED, NOT_READ_WARNING)]
    warnings.insert(0, identified_warning(sizing))
    update: dict = {
        "process": ProcessInfo(
            kind=p.kind, source="identified", gain=p.gain, time_constant_s=p.time_constant_s,
            dead_time_s=p.dead_time_s, sample_time_s=report.process.sample_time_s, description=p.description,
        ),  # fmt: skip
    }
    if not sizing.read:
        update["warnings"] = [*warnings, NOT_READ_PREFIX + sizing.why]
        return report.model_copy(update=update)
    fs, fd, fs_se, fd_se = sizing.fs_fd_pct()
    update |= {
        "method": "identified",
        "s_pct": _opt(sizing.s_pct), "j_pct": _opt(sizing.j_pct),
        "s_se_pct": _opt(sizing.s_se_pct), "j_se_pct": _opt(sizing.j_se_pct),
        "stiction_kind": fault_kind(_opt(sizing.s_pct), _opt(sizing.j_pct), _opt(sizing.j_se_pct)),
        "fs_pct": _opt(fs), "fd_pct": _opt(fd), "fs_se_pct": _opt(fs_se), "fd_se_pct": _opt(fd_se),
        "estimate_t_end_s": t_end_s,
        "warnings": warnings + ([note] if note else []),
    }  # fmt: skip
    return report.model_copy(update=update)


def needs_sizing(report: StictionReport) -> bool:
    """Whether a sizing under an identified process would change ``report``: a loop called sticky
    whose process is neither declared nor identified as the thesis's."""
    return report.verdict == "stiction" and report.process.source == "none"


def with_sizing_and_model(report: StictionReport, details, sizing: Sizing, t_end_s: float | None, note=None):
    """``with_sizing``, and the details (``quantify.pipeline.Details`` or None) with the identified
    model's PV where the sizing was made from this very window (``note`` None) and carries it."""
    report = with_sizing(report, sizing, t_end_s, note)
    if note is None and details is not None and sizing.model_pv_pct is not None:
        details = dataclasses.replace(details, model_pv=sizing.model_pv_pct)
    return report, details


def quantify_sized(quantifier, windows, details: bool = False) -> list[tuple[StictionReport, object]]:
    """``(report, details)`` of each window as ``stiction quantify`` makes them, every sizing done
    here in turn (``quantifier``: an ``quantify.pipeline.Quantifier``; details None unless asked)."""
    out = []
    for w, r in zip(windows, quantifier.results(windows, details=details), strict=True):
        report, d = r.report, r.details
        if needs_sizing(report):
            sizing = size_safely(w.op, w.pv, w.ts_s, w.loop_id, w.sp)
            report, d = with_sizing_and_model(report, d, sizing, w.t_end_s)
        out.append((report, d))
    return out


def identified_warning(sizing: Sizing) -> str:
    head = f"process identified from OP and PV (stiction diagnose): {sizing.process.description}"
    if not sizing.read:
        return head
    return head + "; S and J are read under it, their uncertainty including the model error measured on simulated " \
        "plant-like loops"  # fmt: skip


def size_in_worker(op: np.ndarray, pv: np.ndarray, ts_s: float, loop_id: str, sp=None) -> Sizing:
    """``size_safely`` for a worker process: the model's PV (for plots) stays behind."""
    from dataclasses import replace

    return replace(size_safely(op, pv, ts_s, loop_id, sp), model_pv_pct=None)


def sizing_pool(workers: int, initializer=None):
    """Worker processes for sizings: spawned (never forked: the agent runs Zenoh's threads), each
    with one BLAS thread (numpy's default takes every core; the workers inherit the setting)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"), initializer=initializer)


def lower_priority() -> None:
    """A sizing worker's initializer: it yields the CPU to the agent's reports."""
    with contextlib.suppress(OSError):
        os.nice(10)
