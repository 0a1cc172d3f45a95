"""Without flags an operator sees what a running sim and agent do: a status line every few seconds,
and the health message carries the same rates."""

import json
import re
import signal
import threading

import zenoh

from stiction.bridge import zenoh_session
from stiction.cli import build_parser
from tests.integration.conftest import start_cli, wait_until

PREFIX = "test/status"


def test_sim_and_agent_print_status_lines_and_the_health_carries_the_rates():
    parser = build_parser()
    assert parser.parse_args(["sim"]).status_every == parser.parse_args(["agent"]).status_every == 10.0
    endpoint = zenoh_session.free_loopback_endpoint()
    health = []
    seen = threading.Event()

    def on_health(sample):
        h = json.loads(sample.payload.to_bytes())
        health.append(h)
        if h["reports"]:
            seen.set()

    with zenoh.open(zenoh_session.build(connect=[endpoint], listen=[zenoh_session.free_loopback_endpoint()])) as s:
        sim = start_cli("sim", "--loops", "5", "--speed", "100", "--listen", endpoint, "--prefix", PREFIX,
                     "--status-every", "1")  # fmt: skip
        agent = start_cli("agent", "--connect", endpoint, "--listen", zenoh_session.free_loopback_endpoint(),
                       "--prefix", PREFIX, "--status-every", "1", "--window", "300", "--report-every", "50",
                       "--first-window", "100")  # fmt: skip
        sub = s.declare_subscriber(f"{PREFIX}/agent/*/health", on_health)
        try:
            wait_until(seen.is_set, 60, "a health message counting reports")
        finally:
            sub.undeclare()
            for p in (sim, agent):
                p.send_signal(signal.SIGTERM)
            outs = {name: p.communicate(timeout=20)[0] for name, p in (("sim", sim), ("agent", agent))}
    assert re.search(r"^sim: 5 loops, \d+ samples/s \(100x real time\)", outs["sim"], re.M), outs["sim"]
    lines = re.findall(r"^agent \S+: 5 loops \(5 owned.*samples/s, .* reports/s, .*", outs["agent"], re.M)
    assert lines and "rejected: none" in lines[-1], outs["agent"]
    last = health[-1]
    assert last["samples_per_s"] > 0 and last["reports_per_s"] is not None
