"""``stiction bench bridge``: a simulated plant served over OPC UA, one bridge process, a subscriber.

Three processes on loopback, as in a plant: ``stiction plant`` (the OPC UA server, writing a
sample of every loop each second), ``stiction bridge opcua`` and this process counting what
arrives on ``{prefix}/loop/*/samples/**``.  Measured over the steady phase: samples per loop
against the grid points that passed (lost = missing seq), latency from a sample's grid time to
its arrival, the bridge's CPU (cores) and peak memory.  Then the server is stopped and started
again: seconds from the new server being up to the bridge's first sample of every loop.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from stiction.bench.throughput import _proc_stats
from stiction.bridge import zenoh_session
from stiction.schemas import keys

PREFIX = "bench/bridge"


def _start(*argv: str, stdout=subprocess.DEVNULL) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "stiction.cli", *argv],
        stdout=stdout,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait(condition, timeout_s: float, what: str) -> None:
    tick = threading.Event()
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise RuntimeError(f"bench bridge: timed out waiting for {what}")
        tick.wait(0.1)


def run_bridge_bench(loops: int = 1000, seconds: float = 60.0, restart: bool = True, rate: float | None = None) -> dict:
    """``rate``: the bridge's messages per second per loop (``stiction bridge opcua --rate``; None: its default)."""
    import zenoh

    endpoint = zenoh_session.free_loopback_endpoint()
    opc = f"opc.tcp://127.0.0.1:{zenoh_session.free_loopback_port()}"
    arrivals: dict[str, list[tuple[int, int, float, float]]] = {}  # loop -> (seq, n, t_last, arrival)
    lock = threading.Lock()

    def on_samples(sample) -> None:
        b = json.loads(sample.payload.to_bytes())
        now = time.time()
        with lock:
            arrivals.setdefault(b["loop_id"], []).append(
                (b["seq"], len(b["op"]), b["t0_s"] + (len(b["op"]) - 1) * b["ts_s"], now)
            )

    with tempfile.TemporaryDirectory() as tmp, zenoh.open(zenoh_session.build([endpoint])) as session:
        loop_file = Path(tmp) / "loops.toml"
        plant_args = ["plant", "--loops", str(loops), "--endpoint", opc, "--loop-file", str(loop_file),
                      "--status-every", "5"]  # fmt: skip
        plant_log = open(Path(tmp) / "plant.log", "w")  # noqa: SIM115 - closed with the folder below
        procs = {"plant": _start(*plant_args, stdout=plant_log)}
        sub = session.declare_subscriber(keys.samples_any(PREFIX), on_samples)
        health: list[dict] = []
        hsub = session.declare_subscriber(
            f"{PREFIX}/bridge/*/health", lambda s: health.append(json.loads(s.payload.to_bytes()))
        )
        try:
            _wait(loop_file.exists, 120, "the plant server")
            procs["bridge"] = _start(
                "bridge", "opcua", "--loop-file", str(loop_file), "--prefix", PREFIX, "--connect", endpoint,
                "--listen", zenoh_session.free_loopback_endpoint(), "--status-every", "0",
                *(["--rate", str(rate)] if rate else []),
            )  # fmt: skip
            _wait(lambda: len(arrivals) == loops, 120, f"samples of all {loops} loops")
            time.sleep(3.0)  # past the subscription's first burst
            cpu0 = {k: _proc_stats(p.pid)[0] for k, p in procs.items()}
            t0 = time.time()
            time.sleep(seconds)
            t1 = time.time()
            cpu = {k: (_proc_stats(p.pid)[0] - cpu0[k]) / (t1 - t0) for k, p in procs.items()}
            bridge_rss = _proc_stats(procs["bridge"].pid)[1]
            with lock:
                steady = {k: [a for a in v if t0 <= a[3] <= t1] for k, v in arrivals.items()}
            figures = _steady(steady, loops, t1 - t0)
            figures |= {"loops": loops, "seconds": t1 - t0, "bridge_cores": cpu["bridge"], "plant_cores": cpu["plant"],
                        "rate": rate, "messages_per_s": sum(map(len, steady.values())) / (t1 - t0)}  # fmt: skip
            figures["bridge_peak_rss_mb"] = bridge_rss
            figures["plant_status"] = _last_status(Path(tmp) / "plant.log")
            if health:
                figures |= {
                    "bridge_reconnects_steady": health[-1]["reconnects"],
                    "bridge_dropped": health[-1]["dropped"],
                }
            if restart:
                figures |= _restart(procs, plant_args, loop_file, arrivals, lock, loops)
        finally:
            sub.undeclare()
            hsub.undeclare()
            for p in procs.values():
                if p.poll() is None:
                    p.terminate()
            for p in procs.values():
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()
    return figures


def _last_status(log: Path) -> str | None:
    """The plant's last status line: did the simulated server keep up (samples skipped)?"""
    lines = [x for x in log.read_text().splitlines() if "samples written" in x]
    return lines[-1] if lines else None


def _steady(steady: dict, loops: int, wall_s: float) -> dict:
    lost, received, latency = 0, 0, []
    for batches in steady.values():
        batches = sorted(batches)
        received += sum(n for _, n, _, _ in batches)
        for (s0, n0, _, _), (s1, _, _, _) in zip(batches, batches[1:], strict=False):
            lost += max(0, s1 - (s0 + n0))
        latency += [arrival - t_last for _, _, t_last, arrival in batches]
    lat = np.array(latency)
    return {
        "samples_received": received,
        "samples_per_s": received / wall_s,
        "samples_lost": lost,
        "loops_seen": len(steady),
        "latency_p50_s": float(np.percentile(lat, 50)) if lat.size else None,
        "latency_p99_s": float(np.percentile(lat, 99)) if lat.size else None,
    }


def _restart(procs, plant_args, loop_file: Path, arrivals, lock, loops: int) -> dict:
    """Stop the server, start it again, time the bridge's first sample of every loop after it is up."""
    procs["plant"].terminate()
    procs["plant"].wait(timeout=30)
    down = time.time()
    loop_file.unlink()
    procs["plant"] = _start(*plant_args, stdout=subprocess.DEVNULL)
    _wait(loop_file.exists, 120, "the restarted plant server")
    up = time.time()

    def resumed() -> bool:
        with lock:
            return all(v[-1][3] > up for v in arrivals.values()) and len(arrivals) == loops

    _wait(resumed, 60, "samples of every loop after the restart")
    with lock:
        first_after = [next(a[3] for a in v if a[3] > up) for v in arrivals.values()]
    return {
        "restart_server_down_s": up - down,
        "restart_resume_s": max(first_after) - up,
        "restart_resume_p50_s": float(np.median(np.array(first_after) - up)),
    }


def print_table(f: dict) -> None:
    """The figures as text."""
    print(f"{f['loops']} loops at 1 Hz from an OPC UA server through one bridge, {f['seconds']:.0f} s steady")
    print(
        f"  samples received {f['samples_received']} ({f['samples_per_s']:.0f}/s), lost {f['samples_lost']}, "
        f"loops seen {f['loops_seen']}; {f['messages_per_s']:.0f} messages a second"
        + (f" (--rate {f['rate']:g})" if f.get("rate") else "")
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
