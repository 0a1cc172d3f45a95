"""The agent fits a noisy level loop's valve in the background, as a user runs it: a replayed export declared the
canonical level loop, whose slips PV's noise hides, is reported at once without the fit, and a ``get`` on the
loop's report key then answers with the valve fitted on the agent's worker process (the window not published
twice)."""

import signal
import threading

import pytest
import zenoh

from stiction.bridge import zenoh_session
from stiction.quantify.pipeline import FITTED_WARNING, UNFITTED_WARNING
from stiction.schemas import keys
from stiction.schemas.report import StictionReport
from stiction.sim.disturbance import Disturbance
from stiction.sim.loop import LoopSpec, simulate
from tests.integration.conftest import kill_left_over, start_cli, wait_until

PREFIX = "test/fits"


@pytest.mark.slow
def test_a_replayed_noisy_level_loop_gets_its_valve_fitted_in_the_background(tmp_path):
    spec = LoopSpec(62.3, 21.7, disturbance=Disturbance("gaussian", "output", 0.25), seed=11)
    r = simulate([spec]).kept()
    rows = "\n".join(f"{t},{float(o)!r},{float(p)!r}" for t, (o, p) in enumerate(zip(r.op[0], r.pv[0], strict=True)))
    (tmp_path / "lvl.csv").write_text("t,op,pv\n" + rows + "\n")
    endpoint = zenoh_session.free_loopback_endpoint()
    reports: list[StictionReport] = []
    lock = threading.Lock()

    def on_report(sample):
        with lock:
            reports.append(StictionReport.model_validate_json(sample.payload.to_bytes()))

    procs = {}
    with zenoh.open(zenoh_session.build([endpoint])) as session:
        sub = session.declare_subscriber(keys.all_reports(PREFIX), on_report)
        try:
            common = ["--prefix", PREFIX, "--connect", endpoint]
            procs["agent"] = start_cli("agent", "--first-window", "1000", "--size-every", "1", *common,
                                       "--listen", zenoh_session.free_loopback_endpoint())  # fmt: skip
            wait_until(
                lambda: any(r.ok for r in session.liveliness().get(keys.all_agents(PREFIX), timeout=1)), 30, "agent"
            )
            procs["replay"] = start_cli("replay", str(tmp_path), "--process", "level", "--speed", "2000", "--rate",
                                        "4", *common, "--listen", zenoh_session.free_loopback_endpoint())  # fmt: skip
            assert procs["replay"].wait(timeout=60) == 0
            wait_until(lambda: any(r.verdict == "stiction" for r in reports), 60, "a sticky report")
            with lock:
                first = next(r for r in reports if r.verdict == "stiction")
            assert UNFITTED_WARNING in first.warnings and first.method != "physical"  # at once, not fitted yet

            def latest():
                got = [x.ok for x in session.get(keys.report(PREFIX, "lvl"), timeout=2) if x.ok is not None]
                return StictionReport.model_validate_json(got[0].payload.to_bytes()) if got else None

            # the worker runs at lowered priority and loads the models first
            wait_until(lambda: FITTED_WARNING in (latest() or first).warnings, 300, "the fitted latest report")
            fitted = latest()
            assert fitted.t_end_s == first.t_end_s and fitted.method == "physical"
            assert abs(fitted.fs_pct - spec.fs_pct) <= 2 * fitted.fs_se_pct
            assert abs(fitted.fd_pct - spec.fd_pct) <= 2 * fitted.fd_se_pct
            with lock:
                windows = [(x.loop_id, x.t_end_s) for x in reports]
            assert len(windows) == len(set(windows))  # no window published twice
            procs["agent"].send_signal(signal.SIGTERM)
            assert procs["agent"].wait(timeout=30) == 0
        finally:
            sub.undeclare()
            kill_left_over(procs)
