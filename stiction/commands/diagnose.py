"""``stiction diagnose PATH...``: what the canonical simulation gets wrong on each measured loop, and why.

For every export: the canonical loop is fitted driven by the measured OP, every cause of the
catalogue is tried on top, those that earn their place are named with their parameters,
and the gain in fit is measured (``ident.diagnose``).  ``--json`` prints one object per file
(JSON Lines, ``schemas.diagnosis``); ``--plot DIR`` writes one PNG per loop.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections import deque
from collections.abc import Iterator
from functools import partial
from itertools import chain
from pathlib import Path

from stiction.commands import exports
from stiction.schemas.errors import StictionError, as_stiction_error
from stiction.status import Every

NONE_NAMED = "none: the canonical loop explains the data within its noise"


FIELDS = ("op", "pv", "t", "sp", "mv", "mode")


def add_arguments(p: argparse.ArgumentParser) -> None:
    exports.add_arguments(p, FIELDS)
    p.add_argument("--plot", type=Path, metavar="DIR", help="write one PNG per loop into DIR")
    p.add_argument("--max-causes", type=int, default=4, help="most causes named per loop (default 4)")
    p.add_argument(
        "--jobs",
        type=int,
        default=min(os.cpu_count() or 1, 4),
        help="windows diagnosed at once on worker processes, a core each, answered in the files' order "
        "(default: the cores, at most 4; a single window is diagnosed in this process, its fits on that many "
        "threads)",
    )


def _summary(path: str, r) -> str:
    from stiction.ident.models import is_lag_line
    from stiction.ident.report import causes_text
    from stiction.ident.trust import course_share

    def f(x, nd=2):
        return "-" if x is None else f"{x:.{nd}f}"

    # the record's own limits: on the process type (the process line), on the lag against the band (the friction's)
    limits = [t for t in r.cannot_tell if t.delta_criterion is None and not is_lag_line(t)]
    traded = [t for t in r.cannot_tell if is_lag_line(t)]
    fitted = [t for t in r.cannot_tell if t.delta_criterion is not None]
    causes = causes_text(r)
    lines = [
        f"{path}",
        f"  process: {r.process.description}" + "".join(f" (or {t.note})" for t in limits),
        f"  causes: {causes or (NONE_NAMED if r.candidates else '-')}",
        *([f"  cannot tell: {_ties(fitted, bool(r.causes))}"] if fitted else []),
        f"  fit error: canonical {f(r.base_error, 3)} %, extended {f(r.extended_error, 3)} % (gain {r.gain_pct:.0f} %; "
        f"the extended model {course_share(r.process.pv_explained_share)})",
        _friction_line(r, f),
        *(f"  S and the actuator's lag: {t.note}" for t in traded),
    ]
    if r.valve_check is not None:
        v = r.valve_check
        band = (
            f" ({v.valve.replace('_', '-')} valve: S {f(v.s_pct, 2)} +- {f(v.s_se_pct, 2)}, J {f(v.j_pct, 2)} +- "
            f"{f(v.j_se_pct, 2)} % of OP)"
            if v.model == "sticky"
            else ""
        )
        lines.append(
            f"  valve (OP -> measured stem): {v.model}{band}, actuator lag {v.actuator_tau_s:.2g} s, "
            f"stem = {v.calibration_offset_pct:.2f} + {v.calibration_gain:.3f} OP, error {v.error_pct:.2f} %"
        )
    lines += [f"  warning: {w}" for w in r.warnings]
    return "\n".join(lines)


def _friction_line(r, f) -> str:
    canonical = f"canonical model: fs {f(r.base_friction.fs_pct, 1)}, fd {f(r.base_friction.fd_pct, 1)}"
    if r.s_pct is None and r.fs_pct is None:  # withheld: the warnings below say why
        return f"  S, J: not read (the warnings say why; {canonical})"
    return (
        f"  S {f(r.s_pct)} +- {f(r.s_se_pct)} %  J {f(r.j_pct)} +- {f(r.j_se_pct)} % of span   "
        f"(fs {f(r.fs_pct, 1)} %, fd {f(r.fd_pct, 1)} % of 500 lbf; {canonical})"
    )


def _ties(ties, after_causes: bool) -> str:
    """'dead_time or sensor_lag (sensor_tau_s 3.1), criterion +1.2'; 'none' after named causes is 'nothing more'."""

    def name(cause: str) -> str:
        return "nothing more" if cause == "none" and after_causes else cause

    def one(t) -> str:
        if any(k.endswith(("_low", "_high")) for k in t.parameters):  # an interval: its note says it
            return f"{name(t.named)} or {t.note}"
        params = ", ".join(f"{k} {v:.3g}" for k, v in t.parameters.items())
        params = f" ({params})" if params else ""
        return f"{name(t.named)} or {name(t.alternative)}{params}, criterion {t.delta_criterion:+.1f}"

    return "; ".join(one(t) for t in ties)


def _plot(png: Path, record, d, report) -> Path:
    from stiction.plots import plot_diagnosis

    return plot_diagnosis(png, record, d, report)


PROGRESS_EVERY_S = 10.0


def progress_line(done: int, failed: int, path: str, samples: int, elapsed_s: float) -> str:
    return (
        f"diagnose: {done} window(s) done, {failed} file(s) failed, {elapsed_s:.0f} s; now {path} ({samples} samples)"
    )


def _diagnose(path: Path, export, max_causes: int, threads: int = 1):
    """(report, record, diagnosis) of one window (on a worker process where ``--jobs`` is above 1): the
    export's window whole, as ``--last`` chose it (the reader already says which rows it holds); ``threads``:
    the fits of its search that do not depend on each other run on that many threads (the same diagnosis)."""
    from stiction.ident.report import diagnose_loop

    return diagnose_loop(
        path.stem, export.op, export.pv, export.ts_s, export.mv, export.warnings, export.op.size, max_causes,
        export.sp, threads,
    )  # fmt: skip


def _outcomes(items: Iterator, jobs: int, max_causes: int) -> Iterator:
    """(path, export, (report, record, diagnosis) or the StictionError) of every window, in order.  With
    ``jobs`` above 1 and more than one window, the windows run on that many worker processes, at most
    two each waiting, so that a folder of thousands of exports is read as it is answered."""
    first, second = next(items, None), next(items, None)
    ahead = [x for x in (first, second) if x is not None]
    if jobs <= 1 or second is None:  # one window: its own fits share the cores --jobs allows
        for path, export in chain(ahead, items):
            try:
                yield path, export, _diagnose(path, export, max_causes, threads=jobs if second is None else 1)
            except Exception as e:  # one bad file (or a fault of ours in one) never stops the others
                yield path, export, as_stiction_error(e)
        return
    from stiction.quantify.identified import sizing_pool  # spawned workers, one BLAS thread each

    def done(entry):
        path, export, future = entry
        try:
            return path, export, future.result()
        except Exception as e:
            return path, export, as_stiction_error(e)

    pending: deque = deque()
    with sizing_pool(jobs) as pool:
        for path, export in chain(ahead, items):
            pending.append((path, export, pool.submit(_diagnose, path, export, max_causes)))
            while len(pending) > 2 * jobs:
                yield done(pending.popleft())
        while pending:
            yield done(pending.popleft())


def run(args: argparse.Namespace) -> int:
    from stiction.ident.report import MIN_SAMPLES

    if args.max_causes < 0:
        raise StictionError(f"--max-causes {args.max_causes}: expected 0 or more")
    if args.jobs < 1:
        raise StictionError(f"--jobs {args.jobs}: at least 1")
    failed: list[str] = []
    started, due, done = time.monotonic(), Every(PROGRESS_EVERY_S), 0
    windows = exports.windows(args, "diagnose", FIELDS, MIN_SAMPLES, failed)
    for path, export, outcome in _outcomes(windows, args.jobs, args.max_causes):
        if due():  # a folder of long records takes minutes: say where it is, on stderr (stdout stays the reports')
            print(progress_line(done, len(failed), str(path), export.op.size, time.monotonic() - started),
                  file=sys.stderr, flush=True)  # fmt: skip
        done += 1
        if isinstance(outcome, StictionError):
            failed.append(exports.report_error("diagnose", path, outcome))
            continue
        report, record, d = outcome
        exports.show(
            args, path, export, report, _summary(str(path), report), partial(_plot, record=record, d=d, report=report)
        )
    return 2 if failed else 0
