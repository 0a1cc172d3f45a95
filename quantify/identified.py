"""A report's friction read under the process identified from its own window (``ident.sizing``).

The pipeline's learned models read the thesis's level loop only; a loop called sticky whose
process is neither declared nor identified as the thesis's gets ``method: "none"`` from
them.  ``size_safely`` identifies its process from the loop's window and reads S and J under
it (by ``stiction quantify`` at once, by the agent in the background: ``agent.sizing_plan``),
a failure becoming the reason it read nothing; ``quantify.assembly.assemble`` puts the sizing
into the report.
"""

from __future__ import annotations

import contextlib
import os
import time

import numpy as np

from stiction.ident.sizing import Sizing
from stiction.quantify.assembly import assemble, needs_sizing, with_model
from stiction.schemas.report import StictionReport


def size_safely(op: np.ndarray, pv: np.ndarray, ts_s: float, loop_id: str, sp=None) -> Sizing:
    """``ident.sizing.size``, a failure of the identification becoming the reason nothing was read."""
    from stiction.ident.sizing import size
    from stiction.schemas.errors import StictionError

    try:
        return size(op, pv, ts_s, loop_id, sp)
    except StictionError as e:
        why = str(e)
    except Exception as e:  # noqa: BLE001 - a fit that breaks on one loop must cost that loop's numbers only
        why = f"{type(e).__name__}: {e}"
    nan = float("nan")
    return Sizing(nan, nan, nan, nan, None, 0, f"the process could not be identified ({why})")


def quantify_sized(quantifier, windows, details: bool = False) -> list[tuple[StictionReport, object]]:
    """``(report, details)`` of each window as ``stiction quantify`` makes them, every sizing done
    here in turn (``quantifier``: an ``quantify.pipeline.Quantifier``; details None unless asked)."""
    out = []
    for w, r in zip(windows, quantifier.results(windows, details=details), strict=True):
        sizing = size_safely(w.op, w.pv, w.ts_s, w.loop_id, w.sp) if needs_sizing(r.draft) else None
        out.append((assemble(r.draft, sizing, w.t_end_s), with_model(r.details, sizing)))
    return out


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


TERMINATE_GRACE_S = 2.0
"""How long a sizing worker told to stop (SIGTERM) has before it is killed (``stop_pool``)."""


def stop_pool(pool) -> None:
    """Stop sizing workers now: queued sizings cancelled, one in flight abandoned (its loop is sized again when a
    report next wants it).  ``shutdown(wait=False)`` alone still holds the interpreter's exit until the sizing in
    flight ends: an agent told to stop while a worker fitted a noisy record took that fit's time to exit (over 20 s
    on a loaded host, tests/integration/test_status_lines.py).  Python 3.14's ``terminate_workers`` does this; before
    it, the pool's own process handles are read before its shutdown drops them.  A worker still running
    ``TERMINATE_GRACE_S`` after SIGTERM (one that ignores or blocks it) is killed; the stop returns once every worker's
    exit is known."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    if hasattr(pool, "terminate_workers"):
        pool.terminate_workers()
    else:
        pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            if process.is_alive():
                process.terminate()
    _await_exit(processes, TERMINATE_GRACE_S)
    for process in processes:
        if process.exitcode is None:
            process.kill()
    _await_exit(processes, 1.0)


def _await_exit(processes, timeout_s: float) -> None:
    """Wait until each process's exit code is known, or ``timeout_s``.  Not ``join``: the pool's own thread reaps its
    workers too, and a join (or ``is_alive``) that asks in the instant between that thread's reaping and its noting
    the exit code reads a dead worker as alive (a 3.11 race; it failed tests/quantify/test_sizing_pool.py once in the
    full suite)."""
    deadline = time.monotonic() + timeout_s
    for process in processes:
        while process.exitcode is None and time.monotonic() < deadline:
            time.sleep(0.01)


def lower_priority() -> None:
    """A sizing worker's initializer: it yields the CPU to the agent's reports."""
    with contextlib.suppress(OSError):
        os.nice(10)
