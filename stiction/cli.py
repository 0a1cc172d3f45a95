"""The ``stiction`` command: one console script, one module per subcommand."""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys
import traceback
import warnings
from pathlib import Path

# One BLAS thread for numpy unless the user sets another count, before anything imports numpy: numpy's
# OpenBLAS takes every core for the fits' small matrix products and spins between them, which doubled
# a diagnosis's CPU for no gain in time (2111LIC31102B_1127_0008: 23.3 s wall, 38.8 s CPU with two
# threads; 20.9 s, 17.8 s with one).  torch (``train``) threads through OpenMP and is not affected.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from stiction.heap import hold_freed_memory  # noqa: E402
from stiction.schemas.errors import StictionError  # noqa: E402

COMMANDS = {
    "demo": "the main job: simulator, agent and live table in one process, then a summary",
    "sim": "stream simulated noisy loops over Zenoh",
    "agent": "quantify loops streamed over Zenoh and publish reports",
    "plant": "serve simulated loops over OPC UA, as a plant's control system would",
    "bridge": "bring a plant's loops from its OPC UA server into the Zenoh key space",
    "replay": "stream historian exports into the Zenoh key space at a chosen speed",
    "simulate": "write simulated loops as historian-export CSVs, or the training grid",
    "train": "rebuild every model offline from the simulator",
    "quantify": "stiction reports for historian exports",
    "report": "one HTML page for a plant's loops, ranked, with the evidence (from exports or a live key space)",
    "diagnose": "what the canonical simulation gets wrong on measured loops, why, and what fixing it gains",
    "bench": "benchmarks: simulator speed against the reference",
}


EXAMPLES = {
    "demo": "stiction demo --loops 40 --seconds 60 --rerun spawn",
    "sim": "stiction sim --loops 200 --speed 10 --listen tcp/127.0.0.1:7447",
    "agent": "stiction agent --connect tcp/127.0.0.1:7447 --rerun serve",
    "plant": "stiction plant --loops 100 --endpoint opc.tcp://127.0.0.1:4840 --loop-file loops.toml",
    "bridge": "stiction bridge opcua --loop-file loops.toml --listen tcp/127.0.0.1:7447",
    "replay": "stiction replay ../shared/data/stictiongpt_plant/csv --speed 100",
    "simulate": "stiction simulate --fs-pct 50 --fd-pct 30 --out loop.csv",
    "train": "stiction train --detector",
    "quantify": "stiction quantify exports/ --rank --csv ranked.csv",
    "report": "stiction report exports/ --out plant-report",
    "diagnose": "stiction diagnose exports/FIC101.csv --plot plots/",
    "bench": "stiction bench detect ../shared/data/stictiongpt_plant/csv --loops 40",
}
"""One line a user can copy, shown at the end of each command's --help."""


def build_parser() -> argparse.ArgumentParser:
    from stiction import __version__

    parser = argparse.ArgumentParser(
        prog="stiction",
        description="Which control valves stick, and how much: band S and slip J in % of span.",
        epilog="Example: stiction quantify exports/ --rank   (each command's --help has its own example)",
    )
    parser.add_argument("--version", action="version", version=f"stiction {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="log more (-vv for debug)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, text in COMMANDS.items():
        module = importlib.import_module(f"stiction.commands.{name}")
        p = sub.add_parser(
            name,
            help=text,
            description=(module.__doc__ or text).replace("``", "").strip(),
            epilog=f"example:\n  {EXAMPLES[name]}",
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        module.add_arguments(p)
        p.set_defaults(_module=module)
    return parser


BATCH_COMMANDS = {"quantify", "diagnose", "report", "simulate", "train"}
BATCH_BENCHES = {"sim", "accuracy", "diagnose", "measured", "detect", "sizing"}
"""Commands that compute and exit: their freed arrays stay in the heap for the next (``stiction.heap``; a fifth of
a diagnosis was page faults).  Not the services (the agent, the publishers, the demo, the benchmarks that start
them): an agent at 20,000 loops peaked at 598 MB against 567 MB, and its CPU did not fall."""


def holds_heap(args: argparse.Namespace) -> bool:
    return args.command in BATCH_COMMANDS or (args.command == "bench" and args.bench in BATCH_BENCHES)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if holds_heap(args):
        hold_freed_memory()
    level = [logging.WARNING, logging.INFO, logging.DEBUG][min(args.verbose, 2)]
    logging.basicConfig(level=level, format="%(asctime)s %(name)s %(levelname)s %(message)s")
    if args.verbose == 0:
        # overflow or an empty mean on a user's odd data is named by the checks, not by numpy
        warnings.simplefilter("ignore", RuntimeWarning)
    try:
        return args._module.run(args)
    except StictionError as e:
        print(f"stiction {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # the reader left (``| head``): stop quietly, as Unix tools do
        sys.stderr = open(os.devnull, "w")  # noqa: SIM115 - the interpreter flushes it at exit
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115
        return 0
    except Exception as e:  # a bug: one line for the user, the traceback with -vv
        if args.verbose >= 2:
            raise
        where = traceback.extract_tb(e.__traceback__)[-1]
        print(
            f"stiction {args.command}: internal error: {type(e).__name__}: {e} "
            f"(at {Path(where.filename).name}:{where.lineno}; -vv shows the traceback; please report it)",
            file=sys.stderr,
        )
        return 1


if __name__ == "__main__":
    sys.exit(main())
