"""Two agent processes share the loops; when one dies the other reports its loops (Zenoh liveliness).

The simulator puts each loop on its shard's key: each agent receives and holds only its own shards'
loops, and the survivor rebuilds the dead agent's loops from the simulator's history.

Everything runs as the user would: ``stiction sim`` and two ``stiction agent`` processes on
loopback, and a plain Zenoh subscriber on ``{prefix}/loop/*/report``.
"""

import signal
import threading
import time

import zenoh

from stiction.bridge import zenoh_session
from stiction.schemas import keys
from stiction.schemas.messages import AgentHealth
from stiction.schemas.report import StictionReport
from tests.integration.conftest import kill_left_over, start_cli, wait_until

PREFIX = "test/scale"
LOOPS = 12


def test_two_agents_share_loops_and_take_over(tmp_path):
    endpoint = zenoh_session.free_loopback_endpoint()
    common = ["--prefix", PREFIX]
    agent_args = ["--window", "200", "--report-every", "50", "--connect", endpoint, *common]
    procs = {}
    seen: dict[str, list[tuple[str, float]]] = {}
    lock = threading.Lock()

    def on_report(sample):
        r = StictionReport.model_validate_json(sample.payload.to_bytes())
        with lock:
            seen.setdefault(r.loop_id, []).append((r.agent_id, time.monotonic()))

    health: dict[str, AgentHealth] = {}

    def on_health(sample):
        h = AgentHealth.model_validate_json(sample.payload.to_bytes())
        health[h.agent_id] = h

    with zenoh.open(zenoh_session.build([endpoint])) as session:
        sub = session.declare_subscriber(keys.all_reports(PREFIX), on_report)
        hsub = session.declare_subscriber(f"{PREFIX}/agent/*/health", on_health)
        try:
            for name in ("agent-a", "agent-b"):
                procs[name] = start_cli(
                    "agent", "--agent-id", name, "--listen", zenoh_session.free_loopback_endpoint(), *agent_args
                )

            def alive():
                return {
                    str(r.ok.key_expr)
                    for r in session.liveliness().get(keys.all_agents(PREFIX), timeout=1)
                    if r.ok is not None
                }

            wait_until(lambda: alive() == {keys.agent_token(PREFIX, a) for a in procs}, 60, "both agents' tokens")
            procs["sim"] = start_cli(
                "sim",
                "--loops",
                str(LOOPS),
                "--speed",
                "200",
                "--rate",
                "4",
                "--connect",
                endpoint,
                "--listen",
                zenoh_session.free_loopback_endpoint(),
                *common,
            )
            wait_until(
                lambda: len(seen) == LOOPS and all(len(v) >= 2 for v in seen.values()), 90, "two reports of every loop"
            )
            with lock:
                owners = {loop: {a for a, _ in v} for loop, v in seen.items()}
            assert all(len(o) == 1 for o in owners.values()), owners
            of_a = [loop for loop, o in owners.items() if o == {"agent-a"}]
            assert 0 < len(of_a) < LOOPS  # both agents have work
            # each loop reaches its owner only: no agent holds a copy of the other's loops
            wait_until(lambda: sum(h.loops_seen for h in health.values()) == LOOPS, 10, "health messages")
            assert {a: h.loops_seen for a, h in health.items()} == {"agent-a": len(of_a), "agent-b": LOOPS - len(of_a)}
            assert sorted(h.shards_owned for h in health.values()) == [keys.SHARDS // 2] * 2

            procs["agent-a"].kill()  # no goodbye: only its liveliness token vanishes
            killed = time.monotonic()
            wait_until(
                lambda: all(any(a == "agent-b" and t > killed for a, t in seen[loop]) for loop in of_a),
                60,
                "agent-b to report agent-a's loops",
            )
            assert not any(a == "agent-a" and t > killed + 1.0 for v in seen.values() for a, t in v)

            for name in ("agent-b", "sim"):
                procs[name].send_signal(signal.SIGTERM)
            for name in ("agent-b", "sim"):
                assert procs[name].wait(timeout=20) == 0, procs[name].stderr.read()
        finally:
            sub.undeclare()
            hsub.undeclare()
            kill_left_over(procs)
