"""``stiction diagnose`` as a user runs it: JSON Lines, a summary, plots, bad files named and the rest answered."""

import json
import re
import subprocess
import sys

import numpy as np
import pytest

from stiction.cli import main


@pytest.fixture(scope="module")
def loops(tmp_path_factory):
    d = tmp_path_factory.mktemp("diag")
    main(
        [
            "simulate", "--fs-pct", "40", "--fd-pct", "15", "--dead-time-s", "3", "--disturbance", "gaussian",
            "--coefficient", "0.02", "--out", str(d / "dt.csv"),
        ]
    )  # fmt: skip
    rows = np.genfromtxt(d / "dt.csv", delimiter=",", names=True)
    np.savetxt(d / "dt_no_mv.csv", np.column_stack([rows["t_s"], rows["op"], rows["pv"]]), delimiter=",",
               header="t_s,op,pv", comments="")  # fmt: skip
    (d / "bad.csv").write_text("t,op,pv\n0,1,2\n1,x,2\n")
    (d / "short.csv").write_text("t,op,pv\n" + "".join(f"{i},{i % 7},{i % 5}\n" for i in range(30)))
    return d


def test_json_names_the_cause_and_checks_the_valve_where_mv_is_there(loops, capsys):
    assert main(["diagnose", "--json", str(loops / "dt_no_mv.csv"), str(loops / "dt.csv")]) == 0
    no_mv, with_mv = (json.loads(line) for line in capsys.readouterr().out.strip().splitlines())
    for r in (no_mv, with_mv):
        assert r["cause"] == "dead_time" and r["parameters"]["dead_time_s"] == pytest.approx(3, rel=0.25)
        lo, hi = r["parameter_ranges"]["dead_time_s"]  # every named parameter has its range (about 95 %)
        assert lo < r["parameters"]["dead_time_s"] < hi and lo <= 3 <= hi
        assert r["gain_pct"] > 0 and r["extended_error"] < r["base_error"]
        assert r["fs_pct"] == pytest.approx(40, abs=3) and r["s_se_pct"] > 0
        assert set(r["candidates"]) >= {"dead_time", "deadband", "quantization", "sensor_lag"}
        assert not r["candidates"]["deadband"]["identifiable"]
        # an integrating reading carries the record's limit on a lag: 1000 s of record, a sixth of it
        (limit,) = [t for t in r["cannot_tell"] if t["delta_criterion"] is None]
        assert limit["alternative"] == "process_type"
        assert limit["parameters"]["time_constant_s_low"] == pytest.approx(1000 / 6, rel=0.01)
    assert not no_mv["uses_mv"] and no_mv["valve_check"] is None
    assert with_mv["uses_mv"] and with_mv["valve_check"]["model"] == "sticky"
    assert with_mv["valve_check"]["calibration_gain"] == pytest.approx(1, abs=0.02)


def test_last_longer_than_the_default_cap_is_diagnosed_whole(loops, capsys, monkeypatch):
    """``--last N`` is the window diagnosed, even past the cap a caller without it gets (here 600 samples):
    no second cut, and no advice to use the flag the user just used."""
    monkeypatch.setattr("stiction.ident.report.MAX_SAMPLES", 600)
    assert main(["diagnose", "--json", "--last", "800", str(loops / "dt_no_mv.csv")]) == 0
    r = json.loads(capsys.readouterr().out.strip().splitlines()[0])
    assert r["n_samples"] == 800
    assert not any("--last to choose" in w for w in r["warnings"])
    assert any("800 of 1000 samples" in w for w in r["warnings"])


def test_summary_and_plot(loops, tmp_path, capsys):
    assert main(["diagnose", str(loops / "dt_no_mv.csv"), "--plot", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "causes: dead_time (dead_time_s " in out and "fit error: canonical" in out
    cause = next(line for line in out.splitlines() if "causes:" in line)
    value, lo, hi = (float(x) for x in re.findall(r"dead_time_s ([\d.]+) \(([\d.]+)-([\d.]+)\)", cause)[0])
    assert lo < value < hi  # the value with its range
    process = next(line for line in out.splitlines() if "process:" in line)
    assert "integrating" in process and "or a self-regulating process with a lag of 166.7 s or longer" in process
    png = tmp_path / "dt_no_mv.png"
    assert png.stat().st_size > 20_000


def test_bad_files_are_named_in_one_line_and_the_others_answered(loops):
    done = subprocess.run(
        [sys.executable, "-m", "stiction.cli", "diagnose", "--json", str(loops / "bad.csv"), str(loops / "short.csv"),
         str(loops / "dt_no_mv.csv")],
        capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 2
    errors = done.stderr.strip().splitlines()
    assert len(errors) == 2 and "Traceback" not in done.stderr
    assert "bad.csv: row 3, column 'op': 'x' is not a number" in errors[0]
    assert "short.csv: 30 samples, need at least 100" in errors[1]
    assert json.loads(done.stdout)["loop_id"] == "dt_no_mv"


def test_a_fault_of_ours_in_one_file_is_named_and_the_others_answered(loops, capsys, monkeypatch):
    from stiction.commands import diagnose

    real = diagnose._diagnose

    def failing_on_dt(path, export, max_causes, threads=1):
        if path.stem == "dt":
            raise IndexError("index 5 is out of bounds")
        return real(path, export, max_causes, threads)

    monkeypatch.setattr(diagnose, "_diagnose", failing_on_dt)
    assert main(["diagnose", "--json", "--jobs", "1", str(loops / "dt.csv"), str(loops / "dt_no_mv.csv")]) == 2
    out, err = capsys.readouterr()
    assert [json.loads(line)["loop_id"] for line in out.strip().splitlines()] == ["dt_no_mv"]
    assert "dt.csv: internal error (IndexError: index 5 is out of bounds)" in err and "Traceback" not in err


def test_a_long_run_says_where_it_is_on_stderr_and_the_reports_stay_on_stdout(loops, capsys, monkeypatch):
    from stiction.commands import diagnose as command

    monkeypatch.setattr(command, "PROGRESS_EVERY_S", 1e-9)  # every file, as every 10 s on a long run
    files = [str(loops / name) for name in ("short.csv", "dt_no_mv.csv", "dt.csv")]
    runs = {}
    for jobs in (1, 2):  # in this process, and on two worker processes: the same answers in the same order
        assert main(["diagnose", "--json", "--jobs", str(jobs), *files]) == 2
        runs[jobs] = capsys.readouterr()
    out, err = runs[2]
    assert [json.loads(line)["cause"] for line in out.strip().splitlines()] == ["dead_time", "dead_time"]
    assert [json.loads(line)["loop_id"] for line in out.strip().splitlines()] == ["dt_no_mv", "dt"]
    assert out == runs[1].out
    progress = [line for line in err.splitlines() if "window(s) done" in line]
    assert progress[-1].startswith("diagnose: 1 window(s) done, 1 file(s) failed") and "dt.csv" in progress[-1]
    assert "short.csv: 30 samples, need at least 100" in err
    assert main(["diagnose", "--jobs", "0", files[1]]) == 2
    assert "--jobs 0: at least 1" in capsys.readouterr().err


def test_the_summary_says_s_and_j_were_not_read_instead_of_printing_dashes():
    from types import SimpleNamespace

    from stiction.commands.diagnose import _summary

    base = SimpleNamespace(fs_pct=2.6, fd_pct=2.6)
    common = dict(
        cannot_tell=[], causes=[], parameters={}, candidates={},
        process=SimpleNamespace(description="integrating", pv_explained_share=0.5),
        base_error=1.0, extended_error=0.4, gain_pct=60.0, base_friction=base, valve_check=None,
        warnings=["a valve that does not stick explains PV as well"],
    )  # fmt: skip
    withheld = SimpleNamespace(**common, s_pct=None, s_se_pct=None, j_pct=None, j_se_pct=None, fs_pct=None, fd_pct=None)
    out = _summary("x.csv", withheld)
    assert "S, J: not read (the warnings say why; canonical model: fs 2.6, fd 2.6)" in out and "- +- -" not in out
    assert "(gain 60 %; the extended model explains 50 % of PV's course)" in out
    read = SimpleNamespace(**common, s_pct=3.0, s_se_pct=0.5, j_pct=1.0, j_se_pct=0.2, fs_pct=2.0, fd_pct=1.0)
    assert "S 3.00 +- 0.50 %  J 1.00 +- 0.20 % of span" in _summary("x.csv", read)
