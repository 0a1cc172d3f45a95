"""The agent fits a noisy level loop's valve in the background, as ``stiction quantify`` does at once: its report
goes out without the fit, the fit is made on a worker, and the loop's next reports carry it.  The worker pool runs
each job inline here; the pipeline is the agent's own."""

import json
import time
import zlib
from concurrent.futures import Future

from stiction.agent.core import CoreSettings
from stiction.agent.service import AgentService, AgentSettings
from stiction.quantify.pipeline import FITTED_WARNING, UNFITTED_WARNING
from stiction.schemas import keys
from stiction.schemas.report import StictionReport
from stiction.sim.disturbance import Disturbance
from stiction.sim.loop import DURATION_S, LoopSpec, simulate

PREFIX = "test/fits"


class _Session:
    def __init__(self):
        self.reports: list[StictionReport] = []

    def put(self, key, payload, **kwargs):
        if key.endswith("/report"):
            self.reports.append(StictionReport.model_validate_json(payload))


class _InlinePool:
    """Runs each job as it is submitted (a worker that is done at once)."""

    def __init__(self, fails: bool = False):
        self.jobs, self.fails = 0, fails

    def submit(self, fn, *args):
        self.jobs += 1
        future = Future()
        if self.fails:  # a worker that died: the job's future holds the error
            future.set_exception(RuntimeError("worker died"))
        else:
            future.set_result(fn(*args))
        return future


def _message(loop_id, op, pv, seq):
    body = {"loop_id": loop_id, "seq": seq, "t0_s": float(seq), "ts_s": 1.0, "op": op[seq:].tolist(),
            "pv": pv[seq:].tolist(), "process": "level"}  # fmt: skip
    return keys.samples(PREFIX, loop_id), json.dumps(body).encode(), "application/json", time.monotonic(), False


def test_a_noisy_level_loops_next_reports_carry_the_valve_fitted_in_the_background():
    spec = LoopSpec(62.3, 21.7, disturbance=Disturbance("gaussian", "output", 0.25), seed=11)
    r = simulate([spec], duration_s=DURATION_S + 100.0).kept()
    op, pv = r.op[0], r.pv[0]
    assert op.size >= 1100
    core = CoreSettings(prefix=PREFIX, window_samples=1000, first_report_samples=1000, report_every_samples=100,
                        stagger=False)  # fmt: skip
    session = _Session()
    agent = AgentService(AgentSettings("agent-a", core, size_every_s=600.0), session)
    pool = _InlinePool()
    agent._pool = lambda: pool
    agent._alive = {"agent-a"}
    agent.core.set_agents({"agent-a"})

    agent._inbox.append(_message("lvl", op[:1000], pv[:1000], 0))
    agent.step()
    first = session.reports[-1]
    assert first.verdict == "stiction" and UNFITTED_WARNING in first.warnings and first.method != "physical"
    assert pool.jobs == 1  # the fit went to the worker
    agent.step()  # collected: the loop's latest report (for ``get``) is the fitted one of the same window
    latest = StictionReport.model_validate_json(zlib.decompress(agent.latest["lvl"]))
    assert latest.t_end_s == first.t_end_s and latest.method == "physical" and FITTED_WARNING in latest.warnings
    assert abs(latest.fs_pct - spec.fs_pct) <= 2 * latest.fs_se_pct
    assert len(session.reports) == 1  # not published again
    assert agent.health().loops_fitted == 1

    agent._inbox.append(_message("lvl", op[:1100], pv[:1100], 1000))
    agent.step()
    second = session.reports[-1]
    assert second.t_end_s > first.t_end_s and second.method == "physical" and FITTED_WARNING in second.warnings
    assert second.fs_pct == latest.fs_pct and second.estimate_t_end_s == first.t_end_s
    assert UNFITTED_WARNING not in second.warnings and pool.jobs == 1  # carried, not fitted again before refresh


def test_a_fit_whose_worker_dies_costs_that_fit_only():
    spec = LoopSpec(62.3, 21.7, disturbance=Disturbance("gaussian", "output", 0.25), seed=11)
    r = simulate([spec], duration_s=DURATION_S + 100.0).kept()
    op, pv = r.op[0], r.pv[0]
    core = CoreSettings(prefix=PREFIX, window_samples=1000, first_report_samples=1000, report_every_samples=100,
                        stagger=False)  # fmt: skip
    session = _Session()
    agent = AgentService(AgentSettings("agent-a", core, size_every_s=600.0), session)
    pool = _InlinePool(fails=True)
    agent._pool = lambda: pool
    agent._alive = {"agent-a"}
    agent.core.set_agents({"agent-a"})
    agent._inbox.append(_message("lvl", op[:1000], pv[:1000], 0))
    agent.step()
    agent.step()  # the failed fit is collected: counted, nothing adopted, the agent goes on
    assert pool.jobs == 1 and agent.health().loops_fitted == 1 and not agent._fits
    agent._inbox.append(_message("lvl", op[:1100], pv[:1100], 1000))
    agent.step()
    second = session.reports[-1]
    assert len(session.reports) == 2 and second.verdict == "stiction" and FITTED_WARNING not in second.warnings
    assert pool.jobs == 1  # tried again after the refresh, not at once
