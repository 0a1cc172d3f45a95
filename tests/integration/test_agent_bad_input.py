"""Bad input over real Zenoh: each message is refused with a counted reason, the agent keeps going,
and the good loops' reports are exactly what the offline pipeline gives for the same windows."""

import json
import threading

import numpy as np
import pytest
import zenoh

from stiction.agent.core import CoreSettings
from stiction.agent.service import AgentService, AgentSettings
from stiction.bridge import zenoh_session
from stiction.bridge.publish import encode
from stiction.quantify.pipeline import Window
from stiction.schemas import keys
from stiction.schemas.report import StictionReport
from stiction.sim.grid import case_specs
from stiction.sim.publisher import batch
from stiction.sim.stream import LoopStream
from tests.integration.conftest import wait_until

PREFIX = "test/bad"
WINDOW, EVERY, BATCH = 200, 50, 50  # every batch after the first full window makes a loop due
GOOD = ["C2", "C4", "N6"]


@pytest.fixture
def stack(quantifier):
    endpoint = zenoh_session.free_loopback_endpoint()
    with (
        zenoh.open(zenoh_session.build([endpoint])) as pub,
        zenoh.open(zenoh_session.build(connect=[endpoint], listen=[zenoh_session.free_loopback_endpoint()])) as s,
    ):
        settings = AgentSettings(
            agent_id="t1",
            core=CoreSettings(
                prefix=PREFIX, window_samples=WINDOW, report_every_samples=EVERY, max_loops=len(GOOD) + 6
            ),
            health_every_s=0.2,
        )
        agent = AgentService(settings, s, quantifier).start()
        stop = threading.Event()
        thread = threading.Thread(target=agent.run, args=(stop,), daemon=True)
        thread.start()
        reports: dict[str, list[StictionReport]] = {}
        health: list[dict] = []
        sub_r = pub.declare_subscriber(
            keys.all_reports(PREFIX),
            lambda smp: reports.setdefault(keys.loop_id_of(PREFIX, str(smp.key_expr)), []).append(
                StictionReport.model_validate_json(smp.payload.to_bytes())
            ),
        )
        sub_h = pub.declare_subscriber(
            f"{PREFIX}/agent/*/health", lambda smp: health.append(json.loads(smp.payload.to_bytes()))
        )
        wait_until(lambda: "t1" in agent._alive, 10, "the agent's own liveliness token")
        yield pub, agent, reports, health
        stop.set()
        thread.join(10)
        sub_r.undeclare()
        sub_h.undeclare()
        agent.close()


def _put(session, loop_id, payload, encoding=zenoh.Encoding.APPLICATION_JSON):
    session.put(
        keys.samples(PREFIX, loop_id), payload, encoding=encoding, congestion_control=zenoh.CongestionControl.BLOCK
    )


def test_bad_messages_are_counted_and_good_loops_unaffected(stack, quantifier):
    pub, agent, reports, health = stack
    specs = case_specs(seed=3)
    stream = LoopStream([specs[g] for g in GOOD])
    stream.next(1000)
    sent_op, sent_pv = [[] for _ in GOOD], [[] for _ in GOOD]

    def good(seq, j, chunk):
        return encode(batch(GOOD[j], seq, float(seq), 1.0, chunk.op[j], chunk.pv[j], chunk.sp[j], "level"))

    bad_sent = False
    for _ in range((WINDOW + EVERY) // BATCH):
        chunk = stream.next(BATCH)
        for j in range(len(GOOD)):
            _put(pub, GOOD[j], good(chunk.seq, j, chunk))
            sent_op[j].append(chunk.op[j])
            sent_pv[j].append(chunk.pv[j])
        if not bad_sent:  # every kind of bad input, once, between good batches
            bad_sent = True
            ok = json.loads(good(chunk.seq, 0, chunk))
            lid = GOOD[0]
            _put(pub, "junk", b'{"schema_version": 1, "loop_id": ')
            _put(pub, "junk", json.dumps(ok | {"loop_id": "junk", "schema_version": 9}).encode())
            _put(pub, "junk", json.dumps({"schema_version": 1, "loop_id": "junk", "seq": 0}).encode())
            _put(pub, "junk", json.dumps(ok | {"loop_id": "junk"}).replace(str(ok["op"][0]), "NaN", 1).encode())
            _put(pub, "junk", json.dumps(ok | {"loop_id": "junk", "op": [1e400], "pv": [0.0]}).encode())
            _put(pub, "junk", json.dumps(ok | {"loop_id": "junk", "op": [0.0] * 5000, "pv": [0.0] * 5000}).encode())
            _put(pub, "junk", json.dumps(ok | {"loop_id": "junk"}).encode(), zenoh.Encoding.TEXT_PLAIN)
            _put(pub, lid, good(chunk.seq, 0, chunk))  # the same batch again
            _put(pub, lid, json.dumps(ok | {"op": [9.0] * BATCH}).encode())  # other data for old samples
            for i in range(8):  # a burst of unknown loops beyond max_loops
                _put(pub, f"burst{i}", json.dumps(ok | {"loop_id": f"burst{i}"}).encode())
            _put(pub, "burst0", json.dumps(ok | {"loop_id": "burst0", "seq": ok["seq"] + 500}).encode())

    expected = {
        "malformed_json": 1,
        "wrong_schema_version": 1,
        "missing_field": 1,
        "not_finite": 2,
        "oversized_batch": 1,
        "wrong_encoding": 1,
        "duplicate": 1,
        "out_of_order": 1,
        "too_many_loops": 2,
        "gap": 1,
    }
    last_t = float(chunk.t0_s + BATCH - 1)
    wait_until(
        lambda: all(reports.get(g) and reports[g][-1].t_end_s == last_t for g in GOOD),
        60,
        lambda: f"a report of every good loop's last window, have { {k: len(v) for k, v in reports.items()} }",
    )
    wait_until(lambda: health and health[-1]["rejected"] == expected, 10, f"rejections {expected}")
    for j, g in enumerate(GOOD):
        op, pv = np.concatenate(sent_op[j]), np.concatenate(sent_pv[j])
        last = reports[g][-1]
        # the friction may come from an earlier window of the loop (the agent reads it afresh every
        # --estimate-every reports): the window it names
        end = op.size - int(round(last.t_end_s - last.estimate_t_end_s))
        window = Window(g, op[end - WINDOW : end], pv[end - WINDOW : end], 1.0, last.t_end_s, "level")
        offline = quantifier.quantify([window])[0]
        # the agent holds the samples within 2.4e-7 of the window's range (``agent.coded_ring``): the same reading
        assert last.fs_pct == pytest.approx(offline.fs_pct, rel=1e-5) and last.agent_id == "t1"
        assert last.fd_pct == pytest.approx(offline.fd_pct, rel=1e-5)
    assert "junk" not in reports and not any(k.startswith("burst") for k in reports)


def test_get_answers_the_latest_report(stack):
    pub, agent, reports, _ = stack
    stream = LoopStream([case_specs()["C6"]])
    for _ in range(WINDOW // BATCH):
        chunk = stream.next(BATCH)
        _put(
            pub,
            "C6",
            encode(batch("C6", chunk.seq, float(chunk.seq), 1.0, chunk.op[0], chunk.pv[0], chunk.sp[0], "level")),
        )
    wait_until(lambda: reports.get("C6"), 30, "a report of C6")
    replies = [r.ok for r in pub.get(keys.report(PREFIX, "C6"), timeout=5) if r.ok is not None]
    assert len(replies) == 1
    assert StictionReport.model_validate_json(replies[0].payload.to_bytes()) == reports["C6"][-1]
