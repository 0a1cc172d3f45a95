import contextlib
import subprocess
import sys
import threading
import time

import pytest

from stiction.agent.service import FIT_VALVE
from stiction.quantify.pipeline import Quantifier


def wait_until(condition, timeout_s: float = 30.0, what: str = "condition") -> None:
    """Wait on a condition with a timeout (an Event's wait paces the polling; no bare sleeps)."""
    tick = threading.Event()
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what() if callable(what) else what}")
        tick.wait(0.05)


def start_cli(*argv: str) -> subprocess.Popen:
    """``stiction ARGV...`` as its own process, as a user starts it; output kept for the asserts."""
    return subprocess.Popen(
        [sys.executable, "-m", "stiction.cli", *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def kill_left_over(procs: dict) -> None:
    """Kill whatever a test's processes left running (a test that failed midway)."""
    for p in procs.values():
        if p.poll() is None:
            p.kill()
            p.wait()


@pytest.fixture(scope="session")
def quantifier():
    """As the agent reads (``agent.service.FIT_VALVE``): these tests hold the agent's reports, and its viewer, to
    the offline pipeline.  The fitted reading is left out: on a 200-sample window of a clean loop a range of fs
    breaks away at the same samples, and the agent's samples, held to 2.4e-7 (``agent.coded_ring``), can move the
    fit within that range (C4's first window: fs 70.38 as simulated, 69.91 with 2e-7 of noise added to PV; both
    within their errors of 0.4)."""
    return Quantifier(fit_valve=FIT_VALVE)


@contextlib.contextmanager
def replayed_to_an_agent(prefix: str, folder, agent_args=(), replay_args=()):
    """An agent and ``stiction replay`` of ``folder`` on one key space, as a user starts them, with a session that
    hears every report: yields (the session, the reports heard so far (a function), the processes).  The replay
    has ended (rc 0) when it yields; the agent is left running (stop it to check its exit)."""
    import zenoh

    from stiction.bridge import zenoh_session
    from stiction.schemas import keys
    from stiction.schemas.report import StictionReport

    endpoint = zenoh_session.free_loopback_endpoint()
    reports: list[StictionReport] = []
    lock = threading.Lock()

    def on_report(sample):
        with lock:
            reports.append(StictionReport.model_validate_json(sample.payload.to_bytes()))

    def heard() -> list[StictionReport]:
        with lock:
            return list(reports)

    procs: dict = {}
    with zenoh.open(zenoh_session.build([endpoint])) as session:
        sub = session.declare_subscriber(keys.all_reports(prefix), on_report)
        try:
            common = ["--prefix", prefix, "--connect", endpoint]
            listen = ["--listen", zenoh_session.free_loopback_endpoint()]
            procs["agent"] = start_cli("agent", *agent_args, *common, *listen)
            wait_until(
                lambda: any(r.ok for r in session.liveliness().get(keys.all_agents(prefix), timeout=1)), 30, "agent"
            )
            procs["replay"] = start_cli("replay", str(folder), *replay_args, *common,
                                        "--listen", zenoh_session.free_loopback_endpoint())  # fmt: skip
            assert procs["replay"].wait(timeout=60) == 0
            yield session, heard, procs
        finally:
            sub.undeclare()
            kill_left_over(procs)


def latest_report(session, prefix: str, loop_id: str):
    """The loop's latest report as a ``get`` on its report key answers (None before any)."""
    from stiction.schemas import keys
    from stiction.schemas.report import StictionReport

    got = [x.ok for x in session.get(keys.report(prefix, loop_id), timeout=2) if x.ok is not None]
    return StictionReport.model_validate_json(got[0].payload.to_bytes()) if got else None
