"""``stiction replay`` feeds an agent a plant's recorded loops, as a user runs both: every readable
export gets its reports, a broken one is named on one line and costs the others nothing."""

import shutil
import signal
import subprocess
import sys
import threading

import zenoh

from stiction.bridge import zenoh_session
from stiction.schemas import keys
from stiction.schemas.report import StictionReport
from tests.integration.conftest import kill_left_over, start_cli, wait_until
from tests.measured import PLANT

PREFIX = "test/replay"


def test_replayed_plant_windows_are_reported_and_a_broken_file_is_named(tmp_path):
    import pytest

    if not PLANT.is_dir():
        pytest.skip(f"the measured plant data is not at {PLANT}")
    files = sorted(PLANT.glob("*.csv"))[:3]
    for f in files:
        shutil.copy(f, tmp_path / f.name)
    (tmp_path / "broken.csv").write_text("op,pv\n1,2\n")
    endpoint = zenoh_session.free_loopback_endpoint()
    reports: dict[str, StictionReport] = {}
    lock = threading.Lock()

    def on_report(sample):
        r = StictionReport.model_validate_json(sample.payload.to_bytes())
        with lock:
            reports[r.loop_id] = r

    procs = {}
    with zenoh.open(zenoh_session.build([endpoint])) as session:
        sub = session.declare_subscriber(keys.all_reports(PREFIX), on_report)
        try:
            common = ["--prefix", PREFIX, "--connect", endpoint]
            procs["agent"] = start_cli("agent", "--first-window", "200", "--report-every", "100", *common,
                                    "--listen", zenoh_session.free_loopback_endpoint())  # fmt: skip
            wait_until(
                lambda: any(r.ok for r in session.liveliness().get(keys.all_agents(PREFIX), timeout=1)), 30, "agent"
            )
            procs["replay"] = start_cli("replay", str(tmp_path), "--speed", "2000", "--rate", "4", *common,
                                     "--listen", zenoh_session.free_loopback_endpoint())  # fmt: skip
            assert procs["replay"].wait(timeout=60) == 1  # one file could not be read
            err = procs["replay"].stderr.read()
            assert "broken.csv" in err and len([x for x in err.splitlines() if "error" in x]) == 1
            ids = {f.stem for f in files}
            wait_until(lambda: ids <= set(reports), 30, lambda: f"reports of {ids}, have {set(reports)}")
            for f in files:
                r = reports[f.stem]
                assert r.process.sample_time_s == 10.0 and r.n_samples <= 751 and r.verdict
            procs["agent"].send_signal(signal.SIGTERM)
            assert procs["agent"].wait(timeout=20) == 0
        finally:
            sub.undeclare()
            kill_left_over(procs)


def test_the_demo_shows_replayed_measured_loops_beside_the_simulated_ones(tmp_path):
    import pytest

    if not PLANT.is_dir():
        pytest.skip(f"the measured plant data is not at {PLANT}")
    for f in sorted(PLANT.glob("*.csv"))[:3]:
        shutil.copy(f, tmp_path / f.name)
    (tmp_path / "loops.json").write_text((PLANT.parent / "loops.json").read_text())
    done = subprocess.run(
        [sys.executable, "-m", "stiction.cli", "demo", "--loops", "4", "--seconds", "14", "--speed", "500",
         "--replay", str(tmp_path), "--rerun", "none"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "measured loops (replayed)" in done.stdout
    assert "measured loops: 3 of 3 reported" in done.stdout and "of 3 labelled" in done.stdout


def test_a_replay_nobody_subscribes_to_waits_as_long_as_told_says_so_and_replays_anyway(tmp_path):
    import time

    rows = "\n".join(f"{t},{50 + (t % 7)},{50 + (t % 5)}" for t in range(300))
    (tmp_path / "FIC1.csv").write_text("t,op,pv\n" + rows + "\n")
    t0 = time.monotonic()
    done = subprocess.run(
        [sys.executable, "-m", "stiction.cli", "replay", str(tmp_path), "--speed", "5000", "--wait", "1.5",
         "--prefix", PREFIX, "--listen", zenoh_session.free_loopback_endpoint()],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "1 of 1 loops have no subscriber after 1.5 s; replaying anyway" in done.stderr
    assert "300 samples of 1 loops sent" in done.stderr
    assert time.monotonic() - t0 >= 1.5
