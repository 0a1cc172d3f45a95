"""``stiction bench``: benchmarks that print figures (``--json`` for one JSON object)."""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from pathlib import Path

from schemas.errors import InputError


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


def _print_json(figures) -> None:
    """Every ``bench ... --json`` prints exactly one JSON object."""
    print(json.dumps(figures, default=_plain), flush=True)


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="bench", required=True, metavar="BENCH")
    s = sub.add_parser("sim", help="the training grid's time against the ODE reference")
    s.add_argument("--reference-loops", type=int, default=3, help="grid points run through the slow reference")
    s.add_argument("--repeats", type=int, default=3, help="grid timings; the median is reported")
    s.add_argument("--no-agreement", action="store_true", help="skip the interval-by-interval check (~25 s)")
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
    b.add_argument("--json", action="store_true")
    d = sub.add_parser("diagnose", help="per cause of the catalogue: named, parameter error, gain, fs/fd, time")
    d.add_argument("--loops", type=int, default=20, help="generated loops per cause")
    d.add_argument("--causes", nargs="+", metavar="CAUSE", help="only these causes (default: all, and none)")
    d.add_argument("--workers", type=int, default=2, help="processes (CPU seconds are per loop and core)")
    d.add_argument(
        "--retrain",
        type=Path,
        metavar="DIR",
        help="also retrain the models on each cause into DIR (reused if there) and quantify the same loops with both",
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
    t.add_argument("--loops", type=int, default=20, help="simulated loops per cause in each family")
    t.add_argument("--seed", type=int, default=2026)
    t.add_argument("--json", action="store_true")
    z = sub.add_parser("sizing", help="S and J on simulated plant-like sticky loops, as quantify reports them")
    z.add_argument("--loops", type=int, default=60, help="simulated plant-like loops per class (the sticky ones run)")
    z.add_argument("--seed", type=int, default=2030, help="2026 and 2027 chose the model error (ident.sizing)")
    z.add_argument("--workers", type=int, default=2)
    z.add_argument("--json", action="store_true")
    a = sub.add_parser("accuracy", help="methods x test sets: mean absolute error and time per loop")
    a.add_argument("--realisations", type=int, default=5, help="fresh realisations of each of C1-C10")
    a.add_argument("--seeds", type=int, default=20, help="seeds of each of N1-N10")
    a.add_argument("--holdout", type=int, default=200, help="random loops with random disturbances")
    a.add_argument("--no-hammerstein", action="store_true", help="skip the slowest baseline")
    a.add_argument("--json", action="store_true")


def _machine() -> dict:
    cpu = _cpu_model()
    return {"python": platform.python_version(), "cpus": os.cpu_count(), "cpu": cpu, "machine": platform.machine()}


def _cpu_model() -> str:
    """The CPU's model name (machines of one kind differ up to 2x: every figure names it)."""
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return platform.processor() or "unknown"
    info = dict(line.split(":", 1) for line in lines if ":" in line)
    name = {k.strip(): v.strip() for k, v in info.items()}
    return f"{name.get('model name', 'unknown')} (family {name.get('cpu family', '?')} model {name.get('model', '?')})"


def run(args: argparse.Namespace) -> int:
    BENCHMARKS[args.bench](args)
    return 0


def _sim(args) -> None:
    from bench.sim_speed import bench_agreement, bench_sim

    figures = bench_sim(reference_loops=args.reference_loops, repeats=args.repeats) | {"host": _machine()}
    if not args.no_agreement:
        figures["agreement"] = bench_agreement()
    if args.json:
        _print_json(figures)
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
        if "agreement" in figures:
            a = figures["agreement"]
            print(
                f"  one interval from the reference's state, 20 test cases x {a['intervals_per_case']} samples:"
                f" worst MV difference {a['worst_mv_diff_pct']:.1e} % of span (spec: < 0.05 %),"
                f" worst PV difference {a['worst_pv_diff_pct']:.1e} %, >= {a['min_slips_per_case']} slips a case"
            )


def _sizing(args) -> None:
    from bench.sizing import bench_sizing, print_table

    if args.loops < 1 or args.workers < 1:
        raise InputError(f"--loops {args.loops} --workers {args.workers}: need at least 1 each")
    figures = bench_sizing(args.loops, args.seed, args.workers) | {"host": _machine()}
    if args.json:
        _print_json(figures)
    else:
        print_table(figures)


def _detect(args) -> None:
    from bench.detect import bench_detect, print_table

    missing = [str(f) for f in args.measured if not f.exists()]
    if missing:
        raise InputError(f"{', '.join(missing)}: no such folder or file")
    if args.loops < 1:
        raise InputError(f"--loops {args.loops}: need at least 1")
    figures = bench_detect(args.measured, n_per_class=args.loops, seed=args.seed) | {"host": _machine()}
    if args.json:
        _print_json(figures)
    else:
        print_table(figures)


def _measured(args) -> None:
    from bench.measured import bench_measured, markdown

    missing = [str(f) for f in args.folders if not f.exists()]
    if missing:
        raise InputError(f"{', '.join(missing)}: no such folder or file")
    figures = bench_measured(args.folders, args.workers) | {"host": _machine()}
    if args.json:
        _print_json(figures)
        return
    if args.markdown:
        print(markdown(figures))
    s = figures["summary"]
    c = s["stiction_earns_its_place"]
    print(f"{s['loops']} loops, {s['labelled']} labelled; stiction earns its place (BIC): "
          f"{c['true_positive']} of {c['true_positive'] + c['false_negative']} labelled sticky, "
          f"{c['false_positive']} of {c['false_positive'] + c['true_negative']} labelled not")  # fmt: skip
    print("causes named: " + ", ".join(f"{k} {v}" for k, v in sorted(s["causes"].items(), key=lambda kv: -kv[1])))


def _diagnose(args) -> None:
    from bench.diagnose import bench_diagnose, bench_retrained
    from sim.grid import EFFECT_RANGES

    causes = args.causes or list(EFFECT_RANGES)
    unknown = [c for c in causes if c not in EFFECT_RANGES]
    if unknown:
        raise InputError(f"--causes {' '.join(unknown)}: expected some of {', '.join(EFFECT_RANGES)}")
    if args.loops < 1 or args.workers < 1:
        raise InputError("--loops and --workers must be at least 1")
    quiet = args.json

    def row(c, s):
        if quiet:
            return
        first = ", ".join(f"{k} {v}" for k, v in sorted(s["first_named"].items(), key=lambda kv: -kv[1]))
        param = "-" if s["param_rel_err_median"] is None else f"{100 * s['param_rel_err_median']:.0f} %"
        within = s["fs_fd_within_2se_share"]
        cover = "-" if within is None else f"{100 * within:.0f} %"
        print(
            f"{c:22s} {100 * s['named_share']:5.0f} % {param:>6s} {100 * s['gain_positive_share']:5.0f} % "
            f"{s['fs_fd_mae_canonical_pp']:8.2f} {s['fs_fd_mae_extended_pp']:8.2f} "
            f"{s['fs_fd_read_extended']:3d}/{s['n']:<3d} {cover:>6s} {s['s_per_loop_median']:6.1f}   "
            f"first named: {first}",
            flush=True,
        )

    if not quiet:
        print(f"diagnose on {args.loops} generated loops per cause (noise 1-4 % of PV RMS, OP/PV only)")
        print(
            f"{'cause':22s} {'named':>7s} {'param':>6s} {'gain>0':>7s} {'fs/fd pp':>8s} {'':>8s} {'read':>7s} "
            f"{'in 2se':>6s} {'s/loop':>6s}"
        )
        print(
            f"{'':22s} {'':>7s} {'(med)':>6s} {'':>7s} {'canon.':>8s} {'extend.':>8s} {'':>7s} {'':>6s} {'(CPU)':>6s}"
        )
    figures = bench_diagnose(args.loops, causes, args.workers, progress=row)
    if args.retrain:

        def retrained(c, s):
            if not quiet:
                print(
                    f"  {c:22s} quantify with canonical models {s['quantify_canonical_mae_pp']:6.2f} pp, "
                    f"retrained on {s['extension']} {s['quantify_retrained_mae_pp']:6.2f} pp (n={s['n']})",
                    flush=True,
                )

        if not quiet:
            print("quantify (learned pipeline, no process declared) on loops with each effect at its middle value:")
        figures["retrained"] = bench_retrained(args.loops, causes, args.retrain, progress=retrained)
    figures["host"] = _machine()
    if args.json:
        _print_json(figures)
    else:
        o = figures["overall"]
        print(
            f"overall: effects named {100 * (o['named_share_effects'] or 0):.0f} %, canonical loops given a cause "
            f"{100 * (o['none_given_a_cause'] or 0):.0f} %, fs/fd {o['fs_fd_mae_canonical_pp']:.2f} pp canonical -> "
            f"{o['fs_fd_mae_extended_pp']:.2f} pp extended, {o['s_per_loop_median']:.1f} s per loop (median)"
        )


def _accuracy(args) -> None:
    from bench.accuracy import METHODS, bench_accuracy

    figures = bench_accuracy(
        args.realisations,
        args.seeds,
        args.holdout,
        not args.no_hammerstein,
        progress=lambda name: print(f"  done: {name}", file=sys.stderr),
    ) | {"host": _machine()}
    if args.json:
        _print_json(figures)
        return
    sets = ["C1-C10", "N1-N10", "holdout"]
    print(
        "mean absolute error, percentage points of 500 lbf over fs and fd (thesis Tables 5.1, 5.2); CPU time per loop"
    )
    print(f"{'method':55s}" + "".join(f"{s:>22s}" for s in sets))
    for key, label in METHODS.items():
        row = figures["methods"].get(key)
        if not row:
            continue
        cells = "".join(f"{row[s]['mae_pp']:>9.2f} pp {row[s]['s_per_loop'] * 1e3:>7.1f} ms" for s in sets)
        print(f"{label:55s}{cells}")
    n = {s: figures["methods"]["b_pipeline"][s]["n"] for s in sets}
    print(f"{'loops':55s}" + "".join(f"{n[s]:>22d}" for s in sets))
    for key in ("b_pipeline", "b_no_flags"):  # every loop is sticky: a withheld number is a miss
        row = figures["methods"][key]
        cells = "".join(
            f"{100 * row[s]['called_sticky']:>6.1f} % {row[s]['mae_misses_counted_pp']:>9.2f} pp" for s in sets
        )
        label = {"b_pipeline": "(b)", "b_no_flags": "(b) no flags"}[key] + " called sticky; MAE, misses as zero"
        print(f"{label:55s}{cells}")
    print(f"{'thesis (reported)':55s}{0.65:>9.2f} pp{'':>11s}{1.85:>9.2f} pp")
    found = {s: figures["methods"]["b_no_flags"][s]["identified"] for s in sets}
    cells = ", ".join(f"{s} {found[s]} of {n[s]}" for s in sets)
    print(f"without flags, identified as the thesis's level loop: {cells}")
    used = {s: figures["methods"]["b_pipeline"][s]["methods"] for s in sets}
    print(
        "(b) used: " + "; ".join(f"{s}: " + ", ".join(f"{k} {v}" for k, v in u.items() if v) for s, u in used.items())
    )
    floor = figures["thesis_mlp_chaos_floor"]
    print(
        f"thesis MLP on its own 1275 training patterns {floor['training_realisation']:.2f} pp, on fresh "
        f"realisations of the same grid points {floor['fresh_realisation']:.2f} pp (the chaos floor)"
    )


def _throughput(args) -> None:
    from bench.throughput import missed_goals, run_throughput

    def run(loops: int) -> dict:
        return run_throughput(
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
        ) | {"host": _machine()}

    if args.find_limit:
        return _find_limit(args, run, missed_goals)
    f = run(args.loops)
    if args.json:
        _print_json(f)
        return
    lat = (
        f"p50 {f['latency_p50_s'] * 1e3:.0f} ms, p99 {f['latency_p99_s'] * 1e3:.0f} ms"
        if f["latency_p50_s"] is not None
        else "no reports"
    )
    print(
        f"{f['loops']} {f['mix']} loops at {f['speed']:g} Hz, {f['agents']} agent(s), {f['seconds']:g} s, "
        f"{f['batch_s']:g} s of samples a message on {'shard keys' if f['sharded'] else 'the spec key'}"
    )
    print(f"  verdicts reported: {', '.join(f'{k} {v}' for k, v in sorted(f['verdicts'].items()))}")
    print(
        f"  samples/s ingested {f['samples_per_s']:.0f}   reports/s {f['reports_per_s']:.1f} "
        f"({f['reports']} of {f['reports_expected']} expected)"
    )
    print(
        f"  stiction reports with S and J {f['stiction_reports_with_friction']} of {f['verdicts'].get('stiction', 0)} "
        f"({f['stiction_reports_read_from_own_window']} read from their own window, the others carried a recent "
        f"reading); readings put off {f['readings_deferred']}"
    )
    settled = f["latency_p99_after_first_interval_s"]
    settled = f"; p99 {settled * 1e3:.0f} ms once every loop has reported" if settled is not None else ""
    print(f"  latency last sample -> report: {lat}{settled}")
    by = " ".join("-" if x is None else f"{x:.2f}" for x in f["latency_p99_by_10s"])
    print(f"  p99 by 10 s of stream (s): {by}")
    print(f"  samples lost {f['samples_lost']}   rejected {f['rejected'] or 'none'}")
    shares = ", ".join(f"{x:.0%}" for x in f["messages_received_share"])
    print(
        f"  messages received by each agent: {shares} of those published; "
        f"windows from history {f['windows_from_history']}"
    )
    killed = f" (agent 0 SIGKILLed at {f['killed_agent_at_s']:.0f} s)" if f["killed_agent_at_s"] is not None else ""
    print(
        f"  exactly once{killed}: {f['reports_duplicated']} reports duplicated, "
        f"{f['report_intervals_missed']} intervals without a report"
    )
    print(
        f"  agent CPU {', '.join(f'{c:.0%}' for c in f['agent_cpu_share'])} of a core, "
        f"peak RSS {f['agent_peak_rss_mb']:.0f} MB; sizing worker "
        f"{', '.join(f'{c:.0%}' for c in f['sizing_worker_cpu_share'])} of a core, {f['loops_sized']} loops sized"
    )
    print(f"  host: {f['host']['cpu']}, {f['host']['cpus']} cores")
    stages = f["agent_cpu_by_stage"]
    print("  agent CPU by stage (cores): " + ", ".join(f"{k} {v:.2f}" for k, v in stages.items()))


def _find_limit(args, run, missed_goals) -> None:
    """Loop counts up by a quarter from ``--loops`` until a run misses a goal."""
    held, runs, loops = None, [], args.loops
    while True:
        f = run(loops)
        missed = missed_goals(f)
        runs.append({"loops": loops, "missed": missed, "figures": f})
        if not args.json:
            p99 = f["latency_p99_s"]
            print(
                f"{loops} loops: p99 {'-' if p99 is None else f'{p99:.2f}'} s, "
                f"{max(f['agent_cpu_share']):.2f} of a core, {f['agent_peak_rss_mb']:.0f} MB, "
                f"{f['samples_lost']} samples lost: " + ("holds" if not missed else "misses " + ", ".join(missed)),
                flush=True,
            )
        if missed:
            break
        held, loops = loops, int(round(loops * 1.25 / 500) * 500) or loops + 500
    if args.json:
        _print_json({"largest_loops_holding_the_goals": held, "runs": runs, "host": _machine()})
        return
    print(
        f"largest loop count that holds the goals here: {held if held is not None else f'none from {args.loops}'} "
        f"({args.agents} agent(s), {args.mix}, {args.batch_s:g} s a message, {args.seconds:g} s live; "
        f"{_cpu_model()}, {os.cpu_count()} cores)"
    )


def _bridge(args) -> None:
    from bench.bridge import run_bridge_bench

    if args.loops < 1 or args.seconds <= 0:
        raise InputError("--loops and --seconds must be positive")
    f = run_bridge_bench(args.loops, args.seconds, restart=not args.no_restart) | {"host": _machine()}
    if args.json:
        _print_json(f)
        return
    print(f"{f['loops']} loops at 1 Hz from an OPC UA server through one bridge, {f['seconds']:.0f} s steady")
    print(
        f"  samples received {f['samples_received']} ({f['samples_per_s']:.0f}/s), lost {f['samples_lost']}, "
        f"loops seen {f['loops_seen']}"
    )
    print(f"  latency grid time -> subscriber: p50 {f['latency_p50_s']:.2f} s, p99 {f['latency_p99_s']:.2f} s")
    print(
        f"  bridge CPU {f['bridge_cores']:.0%} of a core, peak RSS {f['bridge_peak_rss_mb']:.0f} MB "
        f"(plant server {f['plant_cores']:.0%})"
    )
    print(f"  {f['plant_status'] or 'plant: no status line'}")
    print(
        f"  bridge reconnects in the steady phase {f.get('bridge_reconnects_steady', '?')}, "
        f"values dropped {f.get('bridge_dropped') or 'none'}"
    )
    if "restart_resume_s" in f:
        print(
            f"  server restart: down {f['restart_server_down_s']:.1f} s; every loop's samples back "
            f"{f['restart_resume_s']:.1f} s after the server was up (median {f['restart_resume_p50_s']:.1f} s)"
        )


BENCHMARKS = {
    "sim": _sim,
    "accuracy": _accuracy,
    "throughput": _throughput,
    "bridge": _bridge,
    "diagnose": _diagnose,
    "measured": _measured,
    "detect": _detect,
    "sizing": _sizing,
}
"""Each subcommand's runner: it runs its benchmark and prints (or ``--json``: one object)."""
