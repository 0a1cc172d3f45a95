"""``stiction quantify PATH...``: stiction reports for historian exports (``--json``: JSON Lines)."""

from __future__ import annotations

import argparse
import logging
import os
from collections.abc import Iterator
from concurrent.futures import Future
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np

from stiction.commands import exports
from stiction.schemas.errors import StictionError, as_stiction_error

log = logging.getLogger(__name__)

FIELDS = ("op", "pv", "t", "sp", "mv", "mode")


def add_arguments(p: argparse.ArgumentParser) -> None:
    exports.add_arguments(p, FIELDS)
    add_method_arguments(p)
    p.add_argument("--plot", type=Path, metavar="DIR", help="write one PNG per loop into DIR")
    p.add_argument(
        "--rank",
        action="store_true",
        help="plant triage: after every file, a table of the loops ranked by what their valves cost "
        "(sticky first, by band S, then oscillating loops by amplitude)",
    )
    p.add_argument("--csv", type=Path, metavar="FILE", help="with --rank: write the ranked table as CSV too")


def add_method_arguments(p: argparse.ArgumentParser) -> None:
    """How the reports are made (``quantify`` and ``report`` share these)."""
    p.add_argument("--models", type=Path, help="directory with the ONNX models and their cards")
    p.add_argument(
        "--process",
        choices=["level"],
        help="the loop is the canonical level loop (spec/thesis-loop.md): "
        "read fs and fd from its slips where the data allow",
    )
    p.add_argument(
        "--no-identify",
        action="store_true",
        help="skip identifying the process of loops called sticky (seconds each): their S and J then stay null "
        "unless --process is given",
    )
    p.add_argument(
        "--jobs",
        type=int,
        default=min(os.cpu_count() or 1, 4),
        help="worker processes for those identifications (default: the cores, at most 4)",
    )
    p.add_argument(
        "--size-every",
        type=float,
        default=60.0,
        metavar="MINUTES",
        help="with --every: a sticky loop's process is identified and S and J read once in this many minutes "
        "of its data, the windows between carrying that reading (default 60, as the agent)",
    )


def _summary(path: str, r) -> str:
    def f(x, nd=1):
        return "-" if x is None else f"{x:.{nd}f}"

    se = f" +- {f(r.fs_se_pct, 2)}/{f(r.fd_se_pct, 2)}" if r.fs_se_pct is not None else ""
    p = "" if r.stiction_probability is None else f" (stiction probability {r.stiction_probability:.2f})"
    cause = f", likely {r.likely_cause.replace('_', ' ')}" if r.verdict == "other_cause" and r.likely_cause else ""
    cause += f" ({r.stiction_kind.replace('_', '-')})" if r.stiction_kind else ""
    lines = [
        f"{path}",
        f"  verdict {r.verdict.replace('_', ' ')}{cause}{p}",
        f"  S {f(r.s_pct, 2)} +- {f(r.s_se_pct, 2)} %  J {f(r.j_pct, 2)} +- {f(r.j_se_pct, 2)} % of span"
        f"   fs {f(r.fs_pct)} %  fd {f(r.fd_pct)} %  (of 500 lbf){se}"
        if r.s_pct is not None or r.fs_pct is not None
        else "  S, J: not read (the warnings say why)",
        f"  period {f(r.period_s)} s   method {r.method}   denoised {'yes' if r.denoised else 'no'}"
        f"   ood {f(r.ood_score, 2)}   thesis chain: fs {f(r.thesis.fs_pct)} %  fd {f(r.thesis.fd_pct)} %",
        f"  process {_process_line(r.process)}",
    ]
    lines += [f"  warning: {w}" for w in r.warnings]
    return "\n".join(lines)


def _process_line(p) -> str:
    if p.source == "none":
        return "unknown (neither declared with --process nor identified)"
    from stiction.sim.process import LOOPS

    how = "declared"
    if p.source == "identified" and p.description:
        from stiction.ident.trust import course_share

        return f"{p.description} (identified from OP and PV; {course_share(p.pv_explained_share)})"
    if p.source == "identified":
        pi = LOOPS["level"]
        how = (
            f"identified from the record: the thesis's level loop "
            f"(its PI, Kc {pi.controller_gain:g}, Ti {pi.integral_time_s:g} s)"
        )
    gain = f", gain {p.gain:.4g} %/s per %" if p.gain is not None and p.kind == "integrating" else ""
    return f"{p.kind.replace('_', '-')}{gain} ({how})"


def _plot(png: Path, window, report, details) -> Path:
    from stiction.plots import plot_loop

    return plot_loop(png, window, report, details)


CARRIED = (
    "S and J from the process identified in an earlier window of this loop (estimate_t_end_s); "
    "re-read once in --size-every minutes of data"
)


CHUNK = 32
"""Windows quantified before the sizings among them run together on the workers."""


@dataclass
class _Item:
    path: Path
    export: object
    window: object
    result: object
    job: Future | None = None
    """The sizing this window's report shows (done here or on a worker), or None."""
    job_t_end_s: float | None = None
    fresh: bool = False
    stem: object = None
    """The valve check of the window's measured stem (``quantify.stem``), or None."""
    stem_note: str | None = None


@dataclass(frozen=True)
class Quantified:
    """One window's report as the command shows it: sizing and the export's warnings in it."""

    path: Path
    export: object
    window: object
    report: object
    details: object


def quantified(
    args: argparse.Namespace, command: str, failed: list[str], details: bool, in_order: bool = True
) -> Iterator[Quantified]:
    """Every window of every export in ``args.paths``, quantified and sized; a file's error is
    printed as one line and appended to ``failed`` (one bad file never stops the others).
    ``details``: fit the INLPCA curve and keep the identified model's PV, for the plots.
    ``in_order=False``: within a chunk, the windows that wait for no sizing come first, so that
    their caller's work (drawing them) overlaps the sizings running on the workers."""
    from stiction.quantify.pipeline import Quantifier, Window
    from stiction.quantify.stem import stem_check
    from stiction.quantify.window import MIN_SAMPLES

    if args.size_every < 0:
        raise StictionError(f"--size-every {args.size_every:g}: minutes, at least 0")
    if args.jobs < 1:
        raise StictionError(f"--jobs {args.jobs}: at least 1")
    quantifier = Quantifier(args.models)
    sized: dict[str, tuple] = {}  # file -> (end of the window its last sizing was made from, that sizing's job)
    pool = None
    pending: list[_Item] = []
    started: list[_Item] = []  # the chunk before: its sizings run while this one is read
    try:
        for path, export in exports.windows(args, command, FIELDS, MIN_SAMPLES, failed):
            try:
                window = Window(
                    loop_id=path.stem,
                    op=export.op,
                    pv=export.pv,
                    ts_s=export.ts_s,
                    t_end_s=float(export.t_s[-1]),
                    process=args.process,
                    sp=export.sp,
                    interpolated=export.interpolated,
                )
                result = quantifier.results([window], details=details)[0]
                stem, stem_note = stem_check(export.op, export.mv, export.ts_s)
            except Exception as e:  # one bad file (or a fault of ours in one) never stops the others
                log.debug("quantifying %s failed", path, exc_info=True)
                failed.append(exports.report_error(command, path, as_stiction_error(e)))
                continue
            pending.append(_Item(path, export, window, result, stem=stem, stem_note=stem_note))
            if len(pending) >= CHUNK:
                pool = _size(args, pending, sized, pool)
                yield from _finished(started, in_order)
                started, pending = pending, []
        pool = _size(args, pending, sized, pool)
        yield from _finished(started, in_order)
        yield from _finished(pending, in_order)
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)


def run(args: argparse.Namespace) -> int:
    if args.csv and not args.rank:
        raise StictionError("--csv FILE goes with --rank")
    failed: list[str] = []
    ranked: list = []
    # the plot draws the INLPCA curve: fit it on every window
    for q in quantified(args, "quantify", failed, details=bool(args.plot)):
        if args.rank:
            ranked.append((str(q.path), q.report))
            continue
        exports.show(
            args,
            q.path,
            q.export,
            q.report,
            _summary(str(q.path), q.report),
            partial(_plot, window=q.window, report=q.report, details=q.details),
        )
    if args.rank:
        from stiction.ranking import print_ranking, write_csv

        rows = print_ranking(ranked)
        if args.csv:
            write_csv(args.csv, rows)
    return 2 if failed else 0


def _size(args, items: list[_Item], sized: dict, pool):
    """Start the sizings these windows need: a sticky window of unknown process, once in
    ``--size-every`` minutes of its file's data; the windows between share the last one.  On
    ``--jobs`` worker processes (started here when first needed); returns the pool."""
    from stiction.quantify.assembly import needs_sizing
    from stiction.quantify.identified import size_safely, sizing_pool

    for item in items:
        if args.no_identify or not needs_sizing(item.result.draft):
            continue
        last = sized.get(str(item.path))
        t_end = item.window.t_end_s
        if last is not None and t_end - last[0] < 60.0 * args.size_every:
            item.job, item.job_t_end_s = last[1], last[0]
            continue
        w = item.window
        if args.jobs > 1:
            pool = pool or sizing_pool(args.jobs)
            item.job = pool.submit(size_safely, np.asarray(w.op), np.asarray(w.pv), w.ts_s, w.loop_id, w.sp)
        else:
            item.job = Future()
            item.job.set_result(size_safely(np.asarray(w.op), np.asarray(w.pv), w.ts_s, w.loop_id, w.sp))
        item.job_t_end_s, item.fresh = t_end, True
        sized[str(item.path)] = (t_end, item.job)
    return pool


def _finished(items: list[_Item], in_order: bool = True) -> Iterator[Quantified]:
    """The windows' reports with their sizings and the export's warnings: in order, or (``in_order``
    false) those without a sizing to wait for first."""
    from stiction.quantify.assembly import assemble, with_model

    if not in_order:
        items = sorted(items, key=lambda item: item.job is not None)  # stable: otherwise in order
    for item in items:
        sizing = item.job.result() if item.job is not None else None
        note = None if item.fresh else CARRIED
        report = assemble(item.result.draft, sizing, item.job_t_end_s, note, notes=item.export.warnings,
                          stem=item.stem, stem_note=item.stem_note)  # fmt: skip
        details = with_model(item.result.details, sizing if item.fresh else None)
        yield Quantified(item.path, item.export, item.window, report, details)
