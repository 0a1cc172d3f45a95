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
