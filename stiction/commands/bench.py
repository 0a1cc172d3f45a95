"""``stiction bench``: benchmarks that print figures (``--json`` for one JSON object)."""

from __future__ import annotations

import argparse
import json
import os
import platform


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="bench", required=True, metavar="BENCH")
    s = sub.add_parser("sim", help="the training grid's time against the ODE reference")
    s.add_argument("--reference-loops", type=int, default=3, help="grid points run through the slow reference")
    s.add_argument("--repeats", type=int, default=3, help="grid timings; the median is reported")
    s.add_argument("--json", action="store_true")


def _machine() -> dict:
    return {"python": platform.python_version(), "cpus": os.cpu_count(), "machine": platform.machine()}


def run(args: argparse.Namespace) -> int:
    if args.bench == "sim":
        from sim.bench import bench_sim

        figures = bench_sim(reference_loops=args.reference_loops, repeats=args.repeats) | {"host": _machine()}
        if args.json:
            print(json.dumps(figures))
        else:
            print(f"grid: {figures['loops']} loops x {figures['duration_s']:.0f} s, physical valve, one core")
            print(
                f"  fast simulator     {figures['grid_s']:8.2f} s  ({figures['grid_loops_per_s']:.0f} loops/s,"
                f" median of {args.repeats})"
            )
            print(
                f"  ODE reference      {figures['reference_s']:8.0f} s  ({figures['reference_s_per_loop']:.1f} s/loop"
                f" over {args.reference_loops} grid points, extrapolated)"
            )
            print(
                f"  speedup            {figures['speedup']:8.0f} x  (same loops one at a time:"
                f" {figures['speedup_single_loop']:.0f} x)"
            )
    return 0
