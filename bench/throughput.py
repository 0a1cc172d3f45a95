"""``stiction bench throughput``: a replay publisher and agent processes on loopback, at plant scale.

The loops are simulated before the clock starts (so only the agent's cost is measured),
each agent's window is filled in one burst (the clock starts once the agents have ingested
it), then every loop sends ``speed`` samples a second, ``batch_s`` seconds of them a message
(staggered over the loops), for ``seconds``.
Latency is measured outside the agent: from publishing a window's last sample to receiving its
report.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import zenoh

from stiction.bridge import zenoh_session
from stiction.bridge.publish import SamplePublisher
from stiction.schemas import keys
from stiction.sim.publisher import batch, loop_specs
from stiction.sim.stream import LoopStream

PREFIX = "bench/throughput"


def _proc_stats(pid: int) -> tuple[float, float]:
    """(CPU seconds, peak RSS in MB) of a process from /proc."""
    stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    cpu_s = (int(stat[11]) + int(stat[12])) / os.sysconf("SC_CLK_TCK")
    hwm = next(line for line in Path(f"/proc/{pid}/status").read_text().splitlines() if line.startswith("VmHWM"))
    return cpu_s, int(hwm.split()[1]) / 1024


def _children_cpu_s(pid: int) -> float:
    """CPU seconds of a process's live children (the agent's sizing worker and its helpers)."""
    total = 0.0
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            kids = (task / "children").read_text().split()
        except OSError:
            continue
        for kid in kids:
            try:
                total += _proc_stats(int(kid))[0]
            except (OSError, StopIteration):
                continue  # gone meanwhile
    return total


def _exactly_once(rows, interval_s: float) -> dict:
    """Reports of the same loop and window end counted twice, and intervals no report covered."""
    by_loop: dict[str, list[float]] = {}
    for loop_id, t_end, _ in rows:
        by_loop.setdefault(loop_id, []).append(t_end)
    duplicated = missed = 0
    for ends in by_loop.values():
        ends = np.sort(np.asarray(ends))
        unique = np.unique(ends)
        duplicated += ends.size - unique.size
        steps = np.round(np.diff(unique) / interval_s).astype(int)
        missed += int(np.sum(np.maximum(steps - 1, 0)))
    return {"reports_duplicated": duplicated, "report_intervals_missed": missed}


def _loops(mix: str, n: int, window: int, n_live: int):
    """(head, live, process): the first ``window`` and the next ``n_live`` samples of every loop."""
    if mix == "canonical":
        stream = LoopStream(list(loop_specs(n, seed=7).values()))
        stream.next(1000)
        return stream.next(window), stream.next(n_live), "level"
    if mix != "plant":
        raise ValueError(f"mix {mix!r}: canonical or plant")
    from types import SimpleNamespace

    from stiction.sim.plant_loops import CLASSES, plant_loops, simulate_plant, stable

    total = window + n_live
    kept: list = []
    seed = 7
    while len(kept) < n:  # diverged runs (an over-aggressive controller) are dropped, as detect's bench does
        made = simulate_plant(plant_loops(-(-(n - len(kept)) // len(CLASSES)) + 1, seed), 0.5, total)
        kept += [(o, p, sp) for o, p, sp, _ in made if stable(o, p)]
        seed += 1
    op, pv, sp = (np.stack([k[j] for k in kept[:n]]) for j in range(3))

    def part(lo: int, hi: int):  # every loop is streamed at one sample a second, whatever its record's interval
        return SimpleNamespace(seq=lo, t0_s=float(lo), op=op[:, lo:hi], pv=pv[:, lo:hi], sp=sp[:, lo:hi])

    return part(0, window), part(window, total), None


def _profile(health: dict[str, dict]) -> dict[str, float]:
    """The agents' CPU seconds by stage (their health messages), summed over agents."""
    total: dict[str, float] = {}
    for h in list(health.values()):
        for k, v in h.get("cpu_s", {}).items():
            total[k] = total.get(k, 0.0) + v
    return total


def _p99_by_bucket(at: list[tuple[int, float]], samples: int) -> list[float | None]:
    """p99 latency of the reports whose windows ended in each bucket of ``samples`` live samples
    (10 s of stream): where in the run the late reports were."""
    if not at:
        return []
    buckets: dict[int, list[float]] = {}
    for k, x in at:
        buckets.setdefault(k // max(samples, 1), []).append(x)
    last = max(buckets)
    return [float(np.percentile(buckets[b], 99)) if b in buckets else None for b in range(last + 1)]


def run_throughput(
    loops: int = 1000,
    seconds: float = 120.0,
    speed: float = 1.0,
    window: int = 1000,
    report_every: int = 60,
    agents: int = 1,
    kill_after_s: float | None = None,
    mix: str = "canonical",
    size_every_min: float = 60.0,
    batch_s: float = 1.0,
    sharded: bool = True,
) -> dict:
    """``kill_after_s``: SIGKILL the first agent that many seconds into the live phase (the others
    must take its loops over, each interval reported once).  ``mix``: ``canonical`` (the thesis's
    level loop, every valve sticky: the dearest report) or ``plant`` (the plant-like loops of
    ``sim/plant_loops.py``, one sixth sticky, the others look-alikes or noise).  ``batch_s``: seconds of
    stream per message (1: a sample a message at 1 Hz).  ``sharded``: samples on the loops' shard keys
    (each agent receives its own shards), else on the spec's key (every agent receives every loop)."""
    n_live = int(seconds * speed)
    ids = [f"b{i:05d}" for i in range(loops)]
    head, live, process = _loops(mix, loops, window, n_live)
    endpoint = zenoh_session.free_loopback_endpoint()
    received: list[tuple[str, float, float]] = []  # loop, t_end_s, arrival
    verdicts: dict[str, int] = {}
    # stiction reports with S and J; those of them read from their own window
    friction = {"with_numbers": 0, "read_here": 0}
    lock = threading.Lock()

    def on_report(sample):
        r = json.loads(sample.payload.to_bytes())
        with lock:
            received.append((r["loop_id"], r["t_end_s"], time.monotonic()))
            verdicts[r["verdict"]] = verdicts.get(r["verdict"], 0) + 1
            if r["verdict"] == "stiction":
                friction["with_numbers"] += r["s_pct"] is not None
                friction["read_here"] += r["s_pct"] is not None and r["estimate_t_end_s"] == r["t_end_s"]

    health: dict[str, dict] = {}
    procs = []
    # the reports come in on a session of their own: the publisher's session holds a declared publisher per
    # loop, and Zenoh matched every report arriving there against all of them (10,000 loops: 4 ms a report,
    # 0.65 of a core of the bench's receive thread, taken from the agents it measures on a 2-core machine)
    reader_endpoint = zenoh_session.free_loopback_endpoint()
    with (
        zenoh.open(zenoh_session.build([endpoint])) as session,
        zenoh.open(zenoh_session.build([reader_endpoint])) as reader,
    ):
        sub = reader.declare_subscriber(keys.all_reports(PREFIX), on_report)
        hsub = reader.declare_subscriber(
            f"{PREFIX}/agent/*/health", lambda s: health.__setitem__(str(s.key_expr), json.loads(s.payload.to_bytes()))
        )
        for a in range(agents):
            procs.append(
                subprocess.Popen(
                    [
                        sys.executable,
                        "-m",
                        "stiction.cli",
                        "agent",
                        "--agent-id",
                        f"bench-{a}",
                        "--prefix",
                        PREFIX,
                        "--connect",
                        endpoint,
                        "--connect",
                        reader_endpoint,
                        "--listen",
                        zenoh_session.free_loopback_endpoint(),
                        "--window",
                        str(window),
                        "--report-every",
                        str(report_every),
                        "--first-window",  # the burst fills whole windows: measure the steady state
                        str(window),
                        "--size-every",
                        str(size_every_min),
                    ],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.PIPE,
                    text=True,
                )
            )
        tick = threading.Event()
        deadline = time.monotonic() + 60
        while (
            len(
                {
                    r.ok.key_expr
                    for r in session.liveliness().get(keys.all_agents(PREFIX), timeout=1)
                    if r.ok is not None
                }
            )
            < agents
        ):
            if time.monotonic() > deadline:
                raise RuntimeError("agents did not come up")
            tick.wait(0.2)
        while len({len(h.get("agents_alive", [])) for h in health.values()} | {agents}) > 1 or len(health) < agents:
            if time.monotonic() > deadline:
                raise RuntimeError("agents did not see each other")
            tick.wait(0.2)  # each agent has settled on its own shards before the first sample
        tick.wait(1.0)
        out = SamplePublisher(session, PREFIX, sharded=sharded, keep_samples=window)
        ts = 1.0
        # fill the windows in one burst, loop j short of full by j mod report_every samples: loops then fall
        # due at staggered times, as in a plant, not all in the same second
        short = [int(j % report_every) for j in range(loops)]
        for j, loop_id in enumerate(ids):
            sl = slice(short[j], window)
            seq, t0_s = head.seq + short[j], head.t0_s + short[j] * ts
            out.put(batch(loop_id, seq, t0_s, ts, head.op[j, sl], head.pv[j, sl], head.sp[j, sl], process))
        # the burst is set-up, not load: start the clock once every agent has ingested it (for 10,000
        # loops 1-2.5 s here, so the live phase no longer overlaps it)
        holders = 1 if sharded else min(agents, 2)  # the owner, and on the spec's key the replica too
        filled = int(loops * window - sum(short)) * holders
        fill_started = time.monotonic()
        while sum(h["samples"] for h in health.values()) < filled and time.monotonic() < fill_started + 300:
            tick.wait(0.5)
        fill_s = time.monotonic() - fill_started
        profile0 = _profile(health)
        sent_at = np.zeros((loops, n_live))  # when each loop's live sample went out
        started = time.monotonic()
        cpu0 = [_proc_stats(p.pid)[0] for p in procs]
        children0 = [_children_cpu_s(p.pid) for p in procs]
        per_message = max(int(round(speed * batch_s)), 1)
        # batches of several seconds go out staggered, as a bridge spreads its loops: a loop's batch
        # boundaries are offset by its index, so every second a 1/per_message share of the loops sends
        phase = np.arange(loops) % per_message
        by_phase = [np.flatnonzero(phase == p) for p in range(per_message)]
        pending = np.zeros(loops, dtype=int)  # each loop's first live sample not yet sent
        killed_at = None
        # the second half of a live phase of four report intervals or more: the agents after their cold start
        half = n_live // 2 if n_live >= 4 * report_every and kill_after_s is None else None
        half_at, cpu_half, profile_half = None, None, None
        for k in range(n_live):
            if k == half:
                half_at, profile_half = time.monotonic(), _profile(health)
                cpu_half = [_proc_stats(p.pid)[0] for p in procs]
            if kill_after_s is not None and killed_at is None and k / speed >= kill_after_s:
                killed_stats = _proc_stats(procs[0].pid)
                procs[0].kill()  # SIGKILL: no goodbye, only its liveliness token vanishes
                procs[0].wait()
                killed_at = k
            due = started + k / speed
            wait = due - time.monotonic()
            if wait > 0:
                tick.wait(wait)
            senders = range(loops) if k == n_live - 1 else by_phase[(k + 1) % per_message]
            for j in senders:
                sl = slice(int(pending[j]), k + 1)
                seq, t0_s = live.seq + sl.start, live.t0_s + sl.start * ts
                out.put(batch(ids[j], seq, t0_s, ts, live.op[j, sl], live.pv[j, sl], live.sp[j, sl], process))
                sent_at[j, sl] = time.monotonic()
                pending[j] = k + 1
        publish_s = time.monotonic() - started
        tick.wait(3.0)  # let the last windows report
        tick.wait(2.5)  # and the agents' next health message carry their profile to the end
        profile = {k: v - profile0.get(k, 0.0) for k, v in _profile(health).items()}
        wall = time.monotonic() - started
        stats = [killed_stats if i == 0 and killed_at is not None else _proc_stats(p.pid) for i, p in enumerate(procs)]
        settled_cpu, settled_profile = None, None
        if half_at is not None:
            half_wall = time.monotonic() - half_at
            settled_cpu = [(st[0] - c) / half_wall for st, c in zip(stats, cpu_half, strict=True)]
            settled_profile = {k: (v - profile_half.get(k, 0.0)) / half_wall for k, v in _profile(health).items()}
        children = [_children_cpu_s(p.pid) for p in procs]
        for p in procs:
            p.terminate()
        stopped_late = 0
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:  # a backlogged agent: its figures are taken, stop it hard
                stopped_late += 1
                p.kill()
                p.wait()
        sub.undeclare()
        hsub.undeclare()
        out.close()
    with lock:
        rows = [r for r in received if r[1] is not None and r[1] >= live.t0_s]
    index = {loop_id: j for j, loop_id in enumerate(ids)}
    at = [
        (int(round((t_end - live.t0_s) / ts)), arr - sent_at[index[lid], int(round((t_end - live.t0_s) / ts))])
        for lid, t_end, arr in rows
        if 0 <= int(round((t_end - live.t0_s) / ts)) < n_live
    ]
    lat = np.array([x for _, x in at])
    # after the first report interval: every loop has reported once (the cold start is over)
    settled = np.array([x for k, x in at if k >= report_every])
    samples_agents = sum(h["samples"] for h in health.values())
    rejected = {}
    for h in health.values():
        for k_, v in h["rejected"].items():
            rejected[k_] = rejected.get(k_, 0) + v
    published = int(loops * (window + n_live) - sum(short))
    messages_published = loops + sum(len(by_phase[(k + 1) % per_message]) for k in range(n_live - 1)) + loops
    # loop j is full after live sample short-1 (at the fill if short is 0), then due every report_every samples;
    # only reports of windows ending in the live phase count
    expected_reports = int(sum(n_live // report_every if s == 0 else (n_live - s) // report_every + 1 for s in short))
    return {
        "loops": loops,
        "agents": agents,
        "speed": speed,
        "seconds": seconds,
        "publish_s": publish_s,
        "fill_ingested_s": fill_s,
        "samples_per_s": loops * n_live / publish_s,
        "reports_per_s": len(rows) / wall,
        "reports": len(rows),
        "reports_expected": expected_reports,
        "latency_p50_s": float(np.percentile(lat, 50)) if lat.size else None,
        "latency_p99_s": float(np.percentile(lat, 99)) if lat.size else None,
        "latency_p99_after_first_interval_s": float(np.percentile(settled, 99)) if settled.size else None,
        "latency_p99_by_10s": _p99_by_bucket(at, int(10 * speed)),
        "samples_published": published,
        "samples_ingested": samples_agents,
        # each loop is held by min(agents, 2) agents (its owner and the replica that would inherit it);
        # a killed agent's count stops with it, so the figure means nothing then
        "samples_lost": published * holders - samples_agents if health and killed_at is None else None,
        "sharded": sharded,
        "batch_s": per_message / speed,
        # the share of the published messages each agent received (sharded: about 1/agents)
        "messages_received_share": [
            h.get("messages_received", 0) / max(messages_published, 1) for _, h in sorted(health.items())
        ],
        "windows_from_history": sum(h.get("windows_from_history", 0) for h in health.values()),
        "killed_agent_at_s": None if killed_at is None else killed_at / speed,
        **_exactly_once(rows, report_every * ts),
        "mix": mix,
        "verdicts": verdicts,
        "stiction_reports_with_friction": friction["with_numbers"],
        "stiction_reports_read_from_own_window": friction["read_here"],
        "readings_deferred": sum(h.get("readings_deferred", 0) for h in health.values()),
        "rejected": rejected,
        "agent_cpu_share": [(s[0] - c) / wall for s, c in zip(stats, cpu0, strict=True)],
        # the background sizing of sticky loops of unknown process, on a worker of lowered priority
        "sizing_worker_cpu_share": [(c1 - c0) / wall for c1, c0 in zip(children, children0, strict=True)],
        "loops_sized": sum(h.get("loops_sized", 0) for h in health.values()),
        "loops_fitted": sum(h.get("loops_fitted", 0) for h in health.values()),
        "agent_peak_rss_mb": max(s[1] for s in stats),
        # the same over the live phase's second half (runs of four report intervals or more, no agent killed):
        # what an agent needs once its cold start (every loop's first reading) is over
        "agent_cpu_share_second_half": settled_cpu,
        "agent_cpu_by_stage_second_half": settled_profile,
        # the agents' CPU by stage over the live phase, summed over agents, in cores
        "agent_cpu_by_stage": {k: v / wall for k, v in profile.items()},
        "agents_killed_after_sigterm": stopped_late,
    }
