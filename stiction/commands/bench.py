"""``stiction bench``: benchmarks that print figures (``--json`` for one JSON object)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from stiction.schemas.errors import InputError

FAMILY_STARTS = ("rest", "operating_point", "both")
"""``sim.plant_families.START``, named here so that the parser is built without the simulator's imports."""


def _plain(x):
    """numpy scalars and arrays as JSON's numbers and lists."""
    import numpy as np

    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, Path):
        return str(x)
    raise TypeError(f"{type(x).__name__} is not JSON")


def _finite(x):
    """``x`` with every number that is not finite (a share of no windows, a median of none) as None:
    JSON has no NaN, and a dashboard's strict parser refuses the object that holds one."""
    import math

    x = _plain(x) if not isinstance(x, dict | list | tuple | str | int | float | bool | type(None)) else x
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_finite(v) for v in x]
    return x


def _print_json(figures) -> None:
    """Every ``bench ... --json`` prints exactly one JSON object (strict JSON: not-a-number as null)."""
    print(json.dumps(_finite(figures), allow_nan=False), flush=True)


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="bench", required=True, metavar="BENCH")
    s = sub.add_parser("sim", help="the training grid's time against the ODE reference")
    s.add_argument("--reference-loops", type=int, default=3, help="grid points run through the slow reference")
    s.add_argument("--repeats", type=int, default=3, help="grid timings; the median is reported")
    s.add_argument("--no-agreement", action="store_true", help="skip the interval-by-interval check (~25 s)")
    s.add_argument(
        "--duration-s", type=float, default=2000.0, help="simulated seconds of each loop (default 2000, the grid's)"
    )
    s.add_argument("--json", action="store_true")
    t = sub.add_parser("throughput", help="replay publisher and agent processes on loopback: rates, latency, memory")
    t.add_argument("--loops", type=int, default=1000)
    t.add_argument("--seconds", type=float, default=60.0, help="length of the live phase, wall clock")
    t.add_argument("--speed", type=float, default=1.0, help="samples per loop per second (1 = a plant at 1 Hz)")
    t.add_argument("--agents", type=int, default=1)
    t.add_argument("--report-every", type=int, default=60, help="samples between a loop's reports")
    t.add_argument(
        "--kill-after", type=float, metavar="S", help="SIGKILL the first agent S seconds into the live phase"
    )
    t.add_argument(
        "--mix",
        choices=["canonical", "plant"],
        default="canonical",
        help="canonical: every loop the thesis's sticky level loop (the dearest reports); plant: plant-like "
        "loops, a sixth sticky (default canonical)",
    )
    t.add_argument(
        "--size-every", type=float, default=60.0, metavar="MINUTES", help="the agents' --size-every (default 60)"
    )
    t.add_argument(
        "--batch-s", type=float, default=1.0, metavar="S", help="seconds of stream per message (default 1: one sample)"
    )
    t.add_argument("--unsharded", action="store_true", help="publish on the spec's key, which every agent receives")
    t.add_argument(
        "--find-limit",
        action="store_true",
        help="from --loops up by a quarter a run until a goal is missed (p99 < 1 s, "
        "no sample lost, every report, < 0.6 of a core and < 500 MB an agent): the largest loop count that holds",
    )
    t.add_argument("--json", action="store_true")
    b = sub.add_parser("bridge", help="OPC UA plant server -> bridge -> subscriber: samples lost, latency, CPU")
    b.add_argument("--loops", type=int, default=1000)
    b.add_argument("--seconds", type=float, default=60.0, help="length of the steady phase, wall clock")
    b.add_argument("--no-restart", action="store_true", help="skip the server restart")
    b.add_argument("--rate", type=float, help="the bridge's messages per second per loop (its --rate)")
    b.add_argument("--json", action="store_true")
    d = sub.add_parser("diagnose", help="per cause of the catalogue: named, parameter error, gain, fs/fd, time")
    d.add_argument("--loops", type=int, default=20, help="generated loops per cause")
    d.add_argument("--causes", nargs="+", metavar="CAUSE", help="only these causes (default: all, and none)")
    d.add_argument("--workers", type=int, default=2, help="processes (CPU seconds are per loop and core)")
    d.add_argument(
        "--seed",
        type=int,
        default=None,
        help="draw the loops from this seed instead of the benchmark's own (20261122): other loops, the same "
        "ranges, to see how much a figure owes to its draw",
    )
    d.add_argument(
        "--draws",
        choices=("catalogue", "wide"),
        default="catalogue",
        help="magnitudes over the catalogue's ranges, or wider, as plants have them (sim.grid.WIDE_EFFECT_RANGES)",
    )
    d.add_argument(
        "--retrain",
        type=Path,
        metavar="DIR",
        help="also retrain the models on each cause into DIR (reused if there) and quantify the same loops with both",
    )
    d.add_argument(
        "--samples",
        type=int,
        default=None,
        help="each record's length in samples (default 1000; stiction diagnose reads up to 3600 of an export): "
        "the same loops simulated longer, for the time a long record takes",
    )
    d.add_argument(
        "--simulator",
        choices=("project", "independent"),
        default="project",
        help="the loops from the project's simulator (sim.loop, the one the fit was built beside), or from a second "
        "implementation of the spec's loop and catalogue written apart from it (sim.independent: continuous time, "
        "solve_ivp; a few seconds a loop)",
    )
    d.add_argument("--json", action="store_true")
    m = sub.add_parser("measured", help="diagnose every export of the measured folders beside their labels")
    m.add_argument("folders", nargs="+", type=Path, metavar="DIR", help="folders of exports (or single files)")
    m.add_argument("--workers", type=int, default=2)
    m.add_argument("--markdown", action="store_true", help="print the per-loop table as markdown")
    m.add_argument("--json", action="store_true")
    t = sub.add_parser("detect", help="is it the valve: the detector beside Horch, bicoherence and shape tests")
    t.add_argument(
        "measured", nargs="*", type=Path, metavar="DIR", help="labelled measured exports (a loops.json beside them)"
    )
    t.add_argument(
        "--loops",
        type=int,
        default=60,
        help="simulated loops per cause in each family (default 60: a family's settled balanced accuracy to +- "
        "0.03-0.06, two errors; at 20, +- 0.06-0.20)",
    )
    t.add_argument("--seed", type=int, default=2026)
    t.add_argument(
        "--network-draws",
        type=int,
        metavar="N",
        help="family draws each held-out window network is trained on (default the shipped network's, "
        "trainer.window_net.WindowNetSettings.seeds: the bench's longest part, its time grows with them; fewer for a "
        "quicker, weaker look)",
    )
    t.add_argument(
        "--windows",
        action="store_true",
        help="with --json, every window's figures too: the held-out families' (family, cause, label), the independent "
        "simulator's (kind, cause, label) and the measured ones (tag, label), each with our probability, the "
        "statistics' and the network's (for analysis)",
    )
    t.add_argument(
        "--bands",
        choices=("plant", "thesis"),
        default="plant",
        help="the held-out sticky valves' bands: plant-scale (S 0.5-10 %% of span) or the thesis's (S 5-48 %%)",
    )
    t.add_argument(
        "--samples",
        type=int,
        default=None,
        help="length of the held-out records (default 600, the training windows'): the same loops recorded longer",
    )
    t.add_argument(
        "--start",
        choices=FAMILY_STARTS,
        default="operating_point",
        help="where the judged families' loops start: settled at their setpoint (the default: loops in operation, "
        "as a plant's are), from rest (a window's warm-up before the record: the figures before 2026-11-30), or "
        "every other loop each way",
    )
    t.add_argument(
        "--train-start",
        choices=FAMILY_STARTS,
        default="rest",
        help="the same for the families the held-out detectors and networks are trained on (the shipped: rest)",
    )
    t.add_argument("--json", action="store_true")
    z = sub.add_parser("sizing", help="S and J on simulated plant-like sticky loops, as quantify reports them")
    z.add_argument("--loops", type=int, default=60, help="simulated plant-like loops per class (the sticky ones run)")
    z.add_argument("--seed", type=int, default=2030, help="2026 and 2027 chose the model error (ident.sizing)")
    z.add_argument("--workers", type=int, default=2)
    z.add_argument(
        "--simulator",
        choices=("plant", "two_parameter", "families"),
        default="plant",
        help="plant: sim.plant_loops (the physical valve the fit assumes); two_parameter: the independent simulator "
        "(Choudhury's valve under SIMC-tuned flows and levels; --loops per cause); families: the verdict's families "
        "(sim.plant_families: flow, level, slow, detuned; stick-slip, He's valve, backlash; --loops per cause and "
        "family), the records that show the fault",
    )
    z.add_argument(
        "--direct-acting",
        action="store_true",
        help="record every loop as a direct-acting controller would (PV falls as the valve opens: OP as 100 - OP)",
    )
    z.add_argument("--json", action="store_true")
    v = sub.add_parser("stem", help="the valve checked against its measured stem, on simulated stems of three kinds")
    v.add_argument("--stems", type=int, default=30, help="stems of each kind (two-parameter, physical, linear)")
    v.add_argument("--seed", type=int, default=2718, help="321 and 654 chose the model error (ident.valve_check)")
    v.add_argument("--json", action="store_true")
    a = sub.add_parser("accuracy", help="methods x test sets: mean absolute error and time per loop")
    a.add_argument("--realisations", type=int, default=5, help="fresh realisations of each of C1-C10")
    a.add_argument("--seeds", type=int, default=20, help="seeds of each of N1-N10")
    a.add_argument("--holdout", type=int, default=200, help="random loops with random disturbances")
    a.add_argument("--no-hammerstein", action="store_true", help="skip the slowest baseline")
    a.add_argument(
        "--no-fit",
        action="store_true",
        help="read without the valve fitted to noisy level loops, as the agent does (seconds instead of 15 minutes)",
    )
    a.add_argument("--json", action="store_true")


def _host(figures: dict) -> dict:
    from stiction.bench.host import machine

    return figures | {"host": machine()}


def _emit(args, figures: dict, print_text) -> None:
    """``--json``: the figures as one JSON object; else the benchmark's own text."""
    if args.json:
        _print_json(figures)
    else:
        print_text(figures)


def run(args: argparse.Namespace) -> int:
    BENCHMARKS[args.bench](args)
    return 0


def _existing(paths: list[Path]) -> None:
    missing = [str(f) for f in paths if not f.exists()]
    if missing:
        raise InputError(f"{', '.join(missing)}: no such folder or file")


def _sim(args) -> None:
    from stiction.bench.sim_speed import bench_agreement, bench_sim, print_table

    if args.duration_s <= 0 or args.reference_loops < 1 or args.repeats < 1:
        raise InputError("--duration-s, --reference-loops and --repeats must be positive")
    figures = _host(bench_sim(reference_loops=args.reference_loops, duration_s=args.duration_s, repeats=args.repeats))
    figures |= {"repeats": args.repeats, "reference_loops": args.reference_loops}
    if not args.no_agreement:
        figures["agreement"] = bench_agreement()
    _emit(args, figures, print_table)


def _sizing(args) -> None:
    from stiction.bench.sizing import bench_sizing, print_table

    if args.loops < 1 or args.workers < 1:
        raise InputError(f"--loops {args.loops} --workers {args.workers}: need at least 1 each")
    fig = bench_sizing(args.loops, args.seed, args.workers, args.simulator, args.direct_acting)
    _emit(args, _host(fig), print_table)


def _stem(args) -> None:
    from stiction.bench.stem import bench_stem, print_table

    if args.stems < 1:
        raise InputError(f"--stems {args.stems}: need at least 1")
    _emit(args, _host(bench_stem(args.stems, args.seed)), print_table)


def _detect(args) -> None:
    from stiction.bench.detect import bench_detect, print_table

    _existing(args.measured)
    if args.loops < 1:
        raise InputError(f"--loops {args.loops}: need at least 1")
    if args.samples is not None and args.samples < 100:
        raise InputError(f"--samples {args.samples}: need at least 100")
    if args.network_draws is not None and args.network_draws < 1:
        raise InputError(f"--network-draws {args.network_draws}: need at least 1")
    fig = bench_detect(args.measured, n_per_class=args.loops, seed=args.seed, bands=args.bands, samples=args.samples,
                       window_net=_network_settings(args.network_draws), windows=args.windows, start=args.start,
                       train_start=args.train_start)  # fmt: skip
    _emit(args, _host(fig), print_table)


def _network_settings(draws: int | None):
    """The held-out window networks' settings: the shipped network's, on ``draws`` family draws if given."""
    if draws is None:
        return None
    from stiction.trainer.window_net import WindowNetSettings

    return WindowNetSettings(seeds=draws)


def _measured(args) -> None:
    from stiction.bench.measured import bench_measured, markdown, print_summary

    _existing(args.folders)
    figures = _host(bench_measured(args.folders, args.workers))
    if args.markdown and not args.json:
        print(markdown(figures))
    _emit(args, figures, print_summary)


def _diagnose(args) -> None:
    from stiction.bench import diagnose
    from stiction.sim.grid import EFFECT_RANGES

    causes = args.causes or list(EFFECT_RANGES)
    unknown = [c for c in causes if c not in EFFECT_RANGES]
    if unknown:
        raise InputError(f"--causes {' '.join(unknown)}: expected some of {', '.join(EFFECT_RANGES)}")
    if args.loops < 1 or args.workers < 1:
        raise InputError("--loops and --workers must be at least 1")
    if args.samples is not None and args.samples < 200:
        raise InputError(f"--samples {args.samples}: at least 200 (a record a diagnosis can read)")
    if args.samples is not None and args.simulator == "independent":
        raise InputError("--samples: the independent simulator keeps the spec's 1,000 samples")
    if args.retrain and args.simulator == "independent":
        raise InputError("--retrain: with the project's simulator only")
    text = not args.json
    seed = diagnose.SEED if args.seed is None else args.seed
    if text:
        diagnose.print_header(args.loops, args.draws, seed, args.samples, args.simulator)
    progress = diagnose.print_row if text else None
    figures = diagnose.bench_diagnose(args.loops, causes, args.workers, progress=progress, draws=args.draws, seed=seed,
                                      samples=args.samples, simulator=args.simulator)  # fmt: skip
    if args.retrain:
        if text:
            diagnose.print_retrained_header()
        progress = diagnose.print_retrained if text else None
        figures["retrained"] = diagnose.bench_retrained(args.loops, causes, args.retrain, progress=progress)
    _emit(args, _host(figures), diagnose.print_overall)


def _accuracy(args) -> None:
    from stiction.bench.accuracy import bench_accuracy, print_table

    figures = bench_accuracy(
        args.realisations,
        args.seeds,
        args.holdout,
        not args.no_hammerstein,
        progress=lambda name: print(f"  done: {name}", file=sys.stderr),
        fit_valve=not args.no_fit,
    )
    _emit(args, _host(figures), print_table)


def _throughput(args) -> None:
    from stiction.bench.throughput import run_throughput
    from stiction.bench.throughput_report import find_limit, print_limit, print_step, print_table

    def run(loops: int) -> dict:
        return _host(
            run_throughput(
                loops,
                args.seconds,
                args.speed,
                report_every=args.report_every,
                agents=args.agents,
                kill_after_s=args.kill_after,
                mix=args.mix,
                size_every_min=args.size_every,
                batch_s=args.batch_s,
                sharded=not args.unsharded,
            )
        )

    if not args.find_limit:
        _emit(args, run(args.loops), print_table)
        return
    held, runs = find_limit(run, args.loops, progress=None if args.json else print_step)
    if args.json:
        _print_json(_host({"largest_loops_holding_the_goals": held, "runs": runs}))
    else:
        print_limit(held, args.loops, runs[-1]["figures"])


def _bridge(args) -> None:
    from stiction.bench.bridge import print_table, run_bridge_bench

    if args.loops < 1 or args.seconds <= 0 or (args.rate is not None and not args.rate > 0):
        raise InputError("--loops, --seconds and --rate must be positive")
    figures = run_bridge_bench(args.loops, args.seconds, restart=not args.no_restart, rate=args.rate)
    _emit(args, _host(figures), print_table)


BENCHMARKS = {
    "sim": _sim,
    "accuracy": _accuracy,
    "throughput": _throughput,
    "bridge": _bridge,
    "diagnose": _diagnose,
    "measured": _measured,
    "detect": _detect,
    "sizing": _sizing,
    "stem": _stem,
}
"""Each subcommand's runner: it runs its benchmark and prints (or ``--json``: one object)."""
