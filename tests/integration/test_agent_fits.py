"""The agent fits a noisy level loop's valve in the background, as a user runs it: a replayed export declared the
canonical level loop, whose slips PV's noise hides, is reported at once without the fit, and a ``get`` on the
loop's report key then answers with the valve fitted on the agent's worker process (the window not published
twice)."""

import signal

import pytest

from stiction.quantify.pipeline import FITTED_WARNING, UNFITTED_WARNING
from stiction.sim.disturbance import Disturbance
from stiction.sim.loop import LoopSpec, simulate
from tests.integration.conftest import latest_report, replayed_to_an_agent, wait_until

PREFIX = "test/fits"


@pytest.mark.slow
def test_a_replayed_noisy_level_loop_gets_its_valve_fitted_in_the_background(tmp_path):
    spec = LoopSpec(62.3, 21.7, disturbance=Disturbance("gaussian", "output", 0.25), seed=11)
    r = simulate([spec]).kept()
    rows = "\n".join(f"{t},{float(o)!r},{float(p)!r}" for t, (o, p) in enumerate(zip(r.op[0], r.pv[0], strict=True)))
    (tmp_path / "lvl.csv").write_text("t,op,pv\n" + rows + "\n")
    agent_args = ["--first-window", "1000", "--size-every", "1"]
    replay_args = ["--process", "level", "--speed", "2000", "--rate", "4"]
    with replayed_to_an_agent(PREFIX, tmp_path, agent_args, replay_args) as (session, heard, procs):
        wait_until(lambda: any(r.verdict == "stiction" for r in heard()), 60, "a sticky report")
        first = next(r for r in heard() if r.verdict == "stiction")
        assert UNFITTED_WARNING in first.warnings and first.method != "physical"  # at once, not fitted yet

        # the worker runs at lowered priority and loads the models first
        wait_until(lambda: FITTED_WARNING in (latest_report(session, PREFIX, "lvl") or first).warnings, 300,
                   "the fitted latest report")  # fmt: skip
        fitted = latest_report(session, PREFIX, "lvl")
        assert fitted.t_end_s == first.t_end_s and fitted.method == "physical"
        assert abs(fitted.fs_pct - spec.fs_pct) <= 2 * fitted.fs_se_pct
        assert abs(fitted.fd_pct - spec.fd_pct) <= 2 * fitted.fd_se_pct
        windows = [(x.loop_id, x.t_end_s) for x in heard()]
        assert len(windows) == len(set(windows))  # no window published twice
        procs["agent"].send_signal(signal.SIGTERM)
        assert procs["agent"].wait(timeout=30) == 0
