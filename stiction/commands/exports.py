"""What ``quantify`` and ``diagnose`` share: the export flags, folders expanded, and each file
read in windows with its errors kept to itself (one bad file never stops the others)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from pathlib import Path

from stiction.schemas.errors import InputError, StictionError

DEFAULT_WINDOW = 3600
"""Samples analysed per file by default: the last DEFAULT_WINDOW (``--last``/``--every`` to choose)."""


def add_arguments(p: argparse.ArgumentParser, fields: tuple[str, ...], paths: str = "+", json: bool = True) -> None:
    """The export flags; ``paths`` is the paths' nargs, ``json`` whether the command prints JSON Lines."""
    p.add_argument(
        "paths", nargs=paths, type=Path, metavar="PATH", help="historian exports (CSV or Parquet) or folders of them"
    )
    if json:
        p.add_argument("--json", action="store_true", help="one JSON object per window (JSON Lines)")
    p.add_argument("--ts", type=float, help="sample time [s] for files without a time column (default 1)")
    for field in fields:
        p.add_argument(
            f"--{field}", dest=f"col_{field}", metavar="COLUMN", help=f"the file's name of the {field} column"
        )
    add_pv_span(p)
    p.add_argument(
        "--last", type=int, metavar="N", help=f"analyse the last N samples of each file (default {DEFAULT_WINDOW})"
    )
    p.add_argument(
        "--every",
        type=int,
        metavar="N",
        help="one report per window of --last samples, a new window every N samples (default: the last window only)",
    )


def add_pv_span(p: argparse.ArgumentParser) -> None:
    """``--pv-span LO HI``: PV and SP recorded in engineering units, read as percent of that range."""
    p.add_argument(
        "--pv-span",
        nargs=2,
        type=float,
        metavar=("LO", "HI"),
        help="PV's (and SP's) range in the files' engineering units: read as percent of it (default: percent already)",
    )


def windows(
    args: argparse.Namespace, command: str, fields: tuple[str, ...], min_samples: int, failed: list[str]
) -> Iterator:
    """(path, Export) for every window of every file; a file's error is printed as one line naming
    it, appended to ``failed``, and the next file is read."""
    from stiction.bridge.historian import check_span, expand_paths, read_export, read_windows

    columns = {f: getattr(args, f"col_{f}") for f in fields if getattr(args, f"col_{f}")}
    for flag in ("last", "every"):
        value = getattr(args, flag)
        if value is not None and value < (min_samples if flag == "last" else 1):
            need = min_samples if flag == "last" else 1
            raise StictionError(f"--{flag} {value}: need at least {need} samples")
    length = args.last or DEFAULT_WINDOW
    span = check_span(args.pv_span)  # once, before any file: a bad range is the command's error, not each file's
    for path in expand_paths(args.paths):
        try:
            found = (
                read_windows(path, length, args.every, args.ts, columns, span)
                if args.every
                else [read_export(path, args.ts, columns, last=length, pv_span=span)]
            )
            for export in found:
                if export.op.size < min_samples:
                    gap = "" if export.gap_note is None else f" ({export.gap_note})"
                    raise InputError(f"{path}: {export.op.size} samples, need at least {min_samples}{gap}")
                yield path, export
        except StictionError as e:
            failed.append(report_error(command, path, e))


def report_error(command: str, path: Path, error: Exception) -> str:
    """Print one line naming the file and what was wrong; return it."""
    message = str(error) if str(path) in str(error) else f"{path}: {error}"
    print(f"stiction {command}: error: {message}", file=sys.stderr, flush=True)
    return message


def show(args: argparse.Namespace, path: Path, export, report, summary: str, plot) -> None:
    """Print one window's report (JSON line or summary) and, with ``--plot``, write its PNG
    through ``plot(png_path) -> Path`` (named by the window's last row with ``--every``)."""
    print(report.model_dump_json() if args.json else summary, flush=True)
    if args.plot:
        args.plot.mkdir(parents=True, exist_ok=True)
        name = f"{path.stem}-row{export.last_row}" if args.every else path.stem
        png = plot(args.plot / f"{name}.png")
        if not args.json:
            print(f"  plot: {png}")
