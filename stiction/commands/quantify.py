"""``stiction quantify PATH...``: stiction reports for historian exports (``--json``: JSON Lines)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from schemas.errors import StictionError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("paths", nargs="+", type=Path, metavar="PATH", help="CSV (or parquet) historian exports")
    p.add_argument("--json", action="store_true", help="one JSON report per file (JSON Lines)")
    p.add_argument("--ts", type=float, help="sample time [s] for files without a time column (default 1)")
    for field in ("op", "pv", "t", "sp"):
        p.add_argument(
            f"--{field}", dest=f"col_{field}", metavar="COLUMN", help=f"the file's name of the {field} column"
        )
    p.add_argument("--models", type=Path, help="directory with the ONNX models and their cards")
    p.add_argument(
        "--process",
        choices=["level"],
        help="the loop is the canonical level loop (spec/thesis-loop.md): "
        "read fs and fd from its slips where the data allow",
    )
    p.add_argument("--plot", type=Path, metavar="DIR", help="write one PNG per loop into DIR")
    p.add_argument("--last", type=int, metavar="N", help="quantify only the last N samples of each file")


def _summary(path: str, r) -> str:
    def f(x, nd=1):
        return "-" if x is None else f"{x:.{nd}f}"

    se = f" +- {f(r.fs_se_pct, 2)}/{f(r.fd_se_pct, 2)}" if r.fs_se_pct is not None else ""
    lines = [
        f"{path}",
        f"  fs {f(r.fs_pct)} %  fd {f(r.fd_pct)} %  (of 500 lbf){se}   S {f(r.s_pct)} %  J {f(r.j_pct)} % of span",
        f"  period {f(r.period_s)} s   method {r.method}   denoised {'yes' if r.denoised else 'no'}"
        f"   ood {f(r.ood_score, 2)}   thesis chain: fs {f(r.thesis.fs_pct)} %  fd {f(r.thesis.fd_pct)} %",
    ]
    lines += [f"  warning: {w}" for w in r.warnings]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from agent.historian import read_export
    from agent.pipeline import Quantifier, Window

    quantifier = Quantifier(args.models)
    columns = {f: getattr(args, f"col_{f}") for f in ("op", "pv", "t", "sp") if getattr(args, f"col_{f}")}
    failed = 0
    for path in args.paths:
        try:
            export = read_export(path, args.ts, columns)
            op, pv = export.op, export.pv
            if args.last:
                op, pv = op[-args.last :], pv[-args.last :]
            window = Window(
                loop_id=path.stem, op=op, pv=pv, ts_s=export.ts_s, t_end_s=float(export.t_s[-1]), process=args.process
            )
            report, details = quantifier.quantify_with_details([window])[0]
            if export.warnings:
                report = report.model_copy(update={"warnings": [*report.warnings, *export.warnings]})
        except StictionError as e:  # one bad file never stops the others
            print(f"stiction quantify: error: {e}", file=sys.stderr)
            failed += 1
            continue
        print(report.model_dump_json() if args.json else _summary(str(path), report), flush=True)
        if args.plot:
            from stiction.plots import plot_loop

            args.plot.mkdir(parents=True, exist_ok=True)
            png = plot_loop(args.plot / f"{path.stem}.png", window, report, details)
            if not args.json:
                print(f"  plot: {png}")
    return 2 if failed else 0
