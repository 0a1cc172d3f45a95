"""``stiction report``: one self-contained HTML page for a plant's loops, ranked, with the evidence.

From historian exports (the same reports ``stiction quantify`` makes):

    stiction report ../shared/data/stictiongpt_plant/csv --out plant-report

or from a running agent's key space (the latest report of every loop):

    stiction report --from tcp/127.0.0.1:7447 --prefix stiction/demo --out plant-report

Then open plant-report/stiction-report.html in any browser; the file can be mailed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from stiction.commands import exports, quantify
from stiction.schemas.errors import InputError, StictionError


def add_arguments(p: argparse.ArgumentParser) -> None:
    exports.add_arguments(p, quantify.FIELDS, paths="*", json=False)
    quantify.add_method_arguments(p)
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="folder for stiction-report.html")
    p.add_argument(
        "--from",
        dest="endpoint",
        metavar="ENDPOINT",
        help="collect the latest reports from a running agent's key space instead (e.g. tcp/127.0.0.1:7447)",
    )
    p.add_argument("--prefix", default=None, help="with --from: the key space prefix (default stiction/demo)")
    p.add_argument(
        "--timeout", type=float, default=5.0, metavar="S", help="with --from: how long to wait for the agents' answers"
    )


def run(args: argparse.Namespace) -> int:
    try:
        import jinja2  # noqa: F401
        import matplotlib  # noqa: F401
    except ImportError as e:
        raise StictionError(f"stiction report needs {e.name}: pip install 'stiction[viewer]'") from None
    from stiction import page

    if args.endpoint and args.paths:
        raise StictionError("give historian exports or --from ENDPOINT, not both")
    if not args.endpoint and not args.paths:
        raise StictionError("nothing to report on: give historian exports (files or folders) or --from ENDPOINT")
    if args.endpoint:
        entries = _from_stream(args)
        source = page.describe_source(endpoint=args.endpoint, prefix=args.prefix or _default_prefix())
        failed: list[str] = []
    else:
        entries, failed = _from_exports(args)
        source = page.describe_source(paths=args.paths)
    if not entries:
        why = f" ({len(failed)} files failed)" if failed else ""
        raise InputError(f"no loop could be read: no page written{why}")
    out = page.write(args.out, entries, source)
    verdicts = sorted({e.report.verdict for e in entries})
    counts = ", ".join(f"{sum(e.report.verdict == v for e in entries)} {v.replace('_', ' ')}" for v in verdicts)
    print(f"{out}: {len(entries)} loops ({counts})" + (f"; {len(failed)} files could not be read" if failed else ""))
    return 2 if failed else 0


def _from_exports(args: argparse.Namespace):
    from stiction import page

    failed: list[str] = []
    entries = []
    # the page is ranked: the order they come in does not matter, and drawing overlaps the sizings
    for q in quantify.quantified(args, "report", failed, details=True, in_order=False):
        entries.append(page.LoopEntry(str(q.path), q.report, page.figure_png(q.window, q.report, q.details)))
        if sys.stderr.isatty():  # a progress line for people, nothing in a log
            print(f"\r{len(entries)} loops read", end="", file=sys.stderr, flush=True)
    if entries and sys.stderr.isatty():
        print(file=sys.stderr)
    return entries, failed


def _default_prefix() -> str:
    from stiction.schemas import keys

    return keys.DEFAULT_PREFIX


def _from_stream(args: argparse.Namespace):
    from stiction import page
    from stiction.bridge import zenoh_session
    from stiction.dashboard import latest_reports
    from stiction.schemas import keys

    prefix = args.prefix or _default_prefix()
    try:
        keys.check_prefix(prefix)
    except ValueError as e:
        raise InputError(str(e)) from None
    if args.timeout <= 0:
        raise InputError(f"--timeout {args.timeout:g}: seconds, more than 0")
    cfg = zenoh_session.build(listen=None, connect=[args.endpoint])
    session = zenoh_session.open_session(cfg, f"connect {args.endpoint}")
    try:
        latest, bad = latest_reports(session, prefix, args.timeout)
    finally:
        session.close()
    if bad:
        print(f"stiction report: {bad} replies were not valid reports and were left out", file=sys.stderr)
    if not latest:
        raise InputError(f"no reports under {prefix}/loop/*/report at {args.endpoint} within {args.timeout:g} s")
    return [page.LoopEntry(keys.report(prefix, loop_id), r) for loop_id, r in sorted(latest.items())]
