"""``stiction demo``: simulator, agent and a live table in one process, Zenoh peers on loopback; then a summary."""

from __future__ import annotations

import argparse
import logging
import sys
import threading
import time
from pathlib import Path

import numpy as np

from stiction import zenoh_config
from stiction.bridge import zenoh_session
from stiction.commands.agent import open_sink
from stiction.commands.replay import WAIT_S as REPLAY_WAIT_S
from stiction.commands.replay import publish as replay
from stiction.commands.replay import read_tracks
from stiction.commands.sim import stop_on_signals
from stiction.schemas.errors import InputError

log = logging.getLogger(__name__)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--loops", type=int, default=40)
    p.add_argument("--seconds", type=float, default=60.0, help="wall-clock length of the demo (default 60)")
    p.add_argument("--speed", type=float, default=100.0, help="simulated seconds per second (default 100)")
    p.add_argument("--report-every", type=int, default=120, help="samples between a loop's reports (default 120)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--rows", type=int, default=16, help="loops shown in the live table")
    p.add_argument("--models", help="directory with the ONNX models and their cards")
    p.add_argument(
        "--rerun",
        metavar="MODE",
        default="save:stiction-demo.rrd",
        help="save:PATH (default save:stiction-demo.rrd), spawn, serve (web viewer), or none",
    )
    p.add_argument(
        "--replay",
        action="append",
        type=Path,
        metavar="PATH",
        help="also replay these historian exports (or folders) at --speed beside the simulated loops",
    )
    zenoh_config.add_arguments(p)


def _no_numbers(r) -> str:
    """Why a report has no friction numbers, in a few words: its verdict, or the warning that says."""
    if r.verdict != "stiction":
        return f"verdict {r.verdict.replace('_', ' ')}"
    said = [w for w in r.warnings if w.startswith(("no estimate", "friction not read"))]
    return said[0].split(":")[0] if said else "no estimate"


def _table(reports, truths, rows: int, elapsed: float, published: int, loops: int) -> str:
    from stiction.quantify.assembly import NOT_IDENTIFIED

    lines = [
        f"stiction demo  {elapsed:5.0f} s   {loops} loops   {published} s simulated per loop   "
        f"{len(reports)} loops reported",
        f"{'loop':10s} {'true fs/fd %':>14s} {'est fs/fd %':>14s} {'err pp':>7s} {'method':>9s} "
        f"{'period s':>8s}  status",
    ]
    for loop_id in sorted(truths)[:rows]:
        t = truths[loop_id]
        r = reports.get(loop_id)
        true = f"{t.fs_pct:5.1f}/{t.fd_pct:5.1f}"
        if r is None or r.fs_pct is None:
            why = "waiting for its first report" if r is None else _no_numbers(r)
            lines.append(f"{loop_id:10s} {true:>14s} {'-':>14s} {'':>7s} {'':>9s} {'':>8s}  {why}")
            continue
        err = (abs(r.fs_pct - t.fs_pct) + abs(r.fd_pct - t.fd_pct)) / 2
        status = "; ".join(w.split(":")[0] for w in r.warnings if w != NOT_IDENTIFIED) or "ok"
        period = f"{r.period_s:8.1f}" if r.period_s else f"{'-':>8s}"
        lines.append(
            f"{loop_id:10s} {true:>14s} {r.fs_pct:6.1f}/{r.fd_pct:5.1f}  {err:7.2f} {r.method:>9s} "
            f"{period}  {status}  ({t.disturbance or 'noise-free'})"
        )
    if len(truths) > rows:
        lines.append(f"showing {rows} of {len(truths)} loops (--rows to show more); the summary covers them all")
    return "\n".join(lines)


def _measured_table(reports, labels: dict[str, str | None], rows: int) -> str:
    """The replayed loops: the data authors' label beside the agent's verdict and S."""
    lines = [
        "",
        f"measured loops (replayed)  {sum(i in reports for i in labels)} of {len(labels)} reported",
        f"{'loop':44s} {'label':>10s} {'verdict':>15s} {'S +- se %':>14s} {'period s':>8s}",
    ]
    for loop_id in sorted(labels)[:rows]:
        r = reports.get(loop_id)
        label = labels[loop_id] or "-"
        if r is None:
            lines.append(f"{loop_id[:44]:44s} {label:>10s} {'waiting':>15s}")
            continue
        s = f"{r.s_pct:.2f} +- {r.s_se_pct:.2f}" if r.s_pct is not None and r.s_se_pct is not None else "-"
        period = f"{r.period_s:8.0f}" if r.period_s else f"{'-':>8s}"
        partial = " (partial window)" if r.partial else ""
        lines.append(f"{loop_id[:44]:44s} {label:>10s} {r.verdict:>15s} {s:>14s} {period}{partial}")
    if len(labels) > rows:
        lines.append(f"showing {rows} of {len(labels)} measured loops")
    return "\n".join(lines)


def summarise_measured(reports, labels: dict[str, str | None]) -> dict:
    got = {i: reports[i] for i in labels if i in reports}
    verdicts: dict[str, int] = {}
    for r in got.values():
        verdicts[r.verdict] = verdicts.get(r.verdict, 0) + 1
    labelled = [(r.verdict == "stiction", labels[i] == "stiction") for i, r in got.items() if labels[i]]
    return {
        "loops": len(labels),
        "loops_reported": len(got),
        "verdicts": verdicts,
        "labelled": len(labelled),
        "agree_with_label": sum(called == sticky for called, sticky in labelled),
    }


def summarise(reports, truths, wall_s: float, published: int, health) -> dict:
    pairs = [(r, truths[i]) for i, r in reports.items() if i in truths and r.fs_pct is not None]
    err = np.array([(abs(r.fs_pct - t.fs_pct) + abs(r.fd_pct - t.fd_pct)) / 2 for r, t in pairs])
    thesis = np.array(
        [
            (abs(r.thesis.fs_pct - t.fs_pct) + abs(r.thesis.fd_pct - t.fd_pct)) / 2
            for r, t in pairs
            if r.thesis.fs_pct is not None
        ]
    )
    by_method = {}
    for m in ("physical", "combined", "learned", "thesis"):
        e = [x for (r, _), x in zip(pairs, err, strict=True) if r.method == m]
        if e:
            by_method[m] = {"loops": len(e), "mae_pp": float(np.mean(e))}
    verdicts: dict[str, int] = {}
    for i, r in reports.items():
        if i in truths:
            verdicts[r.verdict] = verdicts.get(r.verdict, 0) + 1
    return {
        "loops": len(truths),
        "loops_reported": sum(verdicts.values()),
        "loops_with_friction": len(pairs),
        "verdicts": verdicts,
        "reports": health.reports,
        "mae_pp": float(err.mean()) if err.size else None,
        "thesis_chain_mae_pp": float(thesis.mean()) if thesis.size else None,
        "by_method": by_method,
        "samples_per_s": health.samples / wall_s,
        "reports_per_s": health.reports / wall_s,
        "latency_p50_s": health.latency_p50_s,
        "latency_p99_s": health.latency_p99_s,
        "rejected": health.rejected,
        "simulated_s_per_loop": published,
        "wall_s": wall_s,
    }


def _measured(paths) -> tuple[list, dict[str, str | None]]:
    """Replay tracks of ``paths``, and each loop's label where a ``loops.json`` gives one."""
    if not paths:
        return [], {}
    from stiction.bench.measured import labels as read_labels

    tracks, failed = read_tracks(paths, None, None, "demo")
    if not tracks:
        raise InputError(f"--replay: nothing to replay ({len(failed)} file(s), none readable)")
    known: dict[str, dict] = {}
    for p in paths:
        known.update(read_labels(p if p.is_dir() else p.parent))
    return tracks, {t.loop_id: known.get(Path(t.source).stem, {}).get("label") for t in tracks}


def run(args: argparse.Namespace) -> int:

    from stiction.agent.core import CoreSettings
    from stiction.agent.service import AgentService, AgentSettings
    from stiction.bridge.publish import SamplePublisher
    from stiction.bridge.replay import Schedule
    from stiction.dashboard import Dashboard
    from stiction.sim.publisher import PublisherSettings
    from stiction.sim.publisher import run as publish

    if args.loops < 1 or args.seconds <= 0 or args.speed <= 0:
        raise InputError("--loops, --seconds and --speed must be positive")
    endpoint = (args.listen or [zenoh_session.free_loopback_endpoint()])[0]
    zenoh_config.from_args(args)  # validates prefix and config flags
    stop = stop_on_signals()
    sim_settings = PublisherSettings(
        prefix=args.prefix, loops=args.loops, seed=args.seed, speed=args.speed, rate_hz=4.0
    )
    published = [0]
    tty = sys.stdout.isatty()
    tracks, labels = _measured(args.replay or [])
    print(
        f"stiction demo: {args.loops} loops at {args.speed:g}x real time for {args.seconds:g} s"
        + (f", {len(tracks)} measured loops replayed beside them" if tracks else "")
        + f", Zenoh on {endpoint}; a loop's first report comes from a partial 200-sample window, "
        "then from full 1000-sample windows",
        flush=True,
    )
    sink = open_sink(None if args.rerun == "none" else args.rerun)
    with (
        zenoh_session.open_session(zenoh_session.build([endpoint])) as sim_s,
        zenoh_session.open_session(
            zenoh_session.build(connect=[endpoint], listen=[zenoh_session.free_loopback_endpoint()])
        ) as agent_s,
        zenoh_session.open_session(
            zenoh_session.build(connect=[endpoint], listen=[zenoh_session.free_loopback_endpoint()])
        ) as dash_s,
    ):
        dashboard = Dashboard(dash_s, args.prefix)
        agent = AgentService(
            AgentSettings(
                agent_id="demo-agent",
                core=CoreSettings(prefix=args.prefix, report_every_samples=args.report_every),
                models_dir=args.models,
            ),
            agent_s,
            sink=sink,
        ).start()
        threads = [
            threading.Thread(
                target=publish,
                args=(sim_settings, sim_s, stop),
                kwargs={"on_tick": lambda n: published.__setitem__(0, n)},
                daemon=True,
            ),
            threading.Thread(target=agent.run, args=(stop,), daemon=True),
        ]
        replayed = None
        if tracks:
            schedule = Schedule(tracks, args.speed)
            replayed = SamplePublisher(sim_s, args.prefix)
            ids = [t.loop_id for t in tracks]

            def play() -> None:  # a measured window's first samples matter: not sent before the agent subscribed
                replayed.wait_for_subscribers(ids, REPLAY_WAIT_S, stop)
                replay(schedule, replayed, stop, 4.0)

            threads.append(threading.Thread(target=play, daemon=True))
        started = time.monotonic()
        for t in threads:
            t.start()
        time.sleep(0.5)
        dashboard.fetch_truths()
        try:
            while not stop.wait(2.0 if tty else 10.0):
                elapsed = time.monotonic() - started
                if tracks:  # replayed files end: their last report may have been sized since
                    dashboard.fetch_latest()
                reports, truths = dashboard.snapshot()
                text = _table(reports, truths, args.rows, elapsed, published[0], args.loops)
                if tracks:
                    text += "\n" + _measured_table(reports, labels, args.rows)
                print(("\033[2J\033[H" if tty else "\n") + text, flush=True)
                if elapsed >= args.seconds:
                    break
        finally:
            stop.set()
            for t in threads:
                t.join(timeout=10)
            wall = time.monotonic() - started
            agent.close()
            if replayed is not None:
                replayed.close()
            dashboard.close()
            if sink is not None:
                sink.close()
    reports, truths = dashboard.snapshot()
    s = summarise(reports, truths, wall, published[0], agent.health())
    print("\nsummary")
    print(
        f"  loops {s['loops']}, reported {s['loops_reported']}, reports {s['reports']} "
        f"({s['reports_per_s']:.1f}/s), samples ingested {s['samples_per_s']:.0f}/s"
    )
    verdicts = ", ".join(f"{n} {v.replace('_', ' ')}" for v, n in sorted(s["verdicts"].items()))
    print(
        f"  verdicts: {verdicts}; friction numbers for {s['loops_with_friction']} "
        "(every simulated valve sticks: the others are the detector's misses)"
    )
    if s["mae_pp"] is not None:
        methods = ", ".join(f"{m} {v['loops']} loops {v['mae_pp']:.2f} pp" for m, v in s["by_method"].items())
        print(
            f"  estimated vs true fs/fd: mean absolute error {s['mae_pp']:.2f} pp of 500 lbf ({methods}); "
            f"thesis chain alone {s['thesis_chain_mae_pp']:.2f} pp"
        )
    if s["latency_p50_s"] is not None:
        print(
            f"  latency from a window's last sample to its report: p50 {s['latency_p50_s'] * 1e3:.0f} ms, "
            f"p99 {s['latency_p99_s'] * 1e3:.0f} ms"
        )
    print(f"  rejected messages: {s['rejected'] or 'none'}")
    if tracks:
        m = summarise_measured(reports, labels)
        verdicts = ", ".join(f"{n} {v.replace('_', ' ')}" for v, n in sorted(m["verdicts"].items())) or "none yet"
        print(
            f"  measured loops: {m['loops_reported']} of {m['loops']} reported ({verdicts}); the verdict agrees "
            f"with the data authors' label on {m['agree_with_label']} of {m['labelled']} labelled"
        )
    if args.rerun.startswith("save:"):
        print(
            f"  rerun recording of the OP-PV loops before and after denoising: {args.rerun[5:]} "
            f"(open it with: rerun {args.rerun[5:]})"
        )
    return 0
