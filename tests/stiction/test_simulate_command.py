"""``stiction simulate`` as a user runs it."""

import json
import subprocess
import sys

import numpy as np
import pytest

from stiction.cli import main
from stiction.sim.export import read_grid


def _read(path):
    return np.genfromtxt(path, delimiter=",", names=True)


def test_console_script_writes_a_stiction_loop(tmp_path):
    out = tmp_path / "loop.csv"
    done = subprocess.run(
        ["stiction", "simulate", "--fs-pct", "50", "--fd-pct", "20", "--out", str(out)], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    data = _read(out)
    assert data.dtype.names == ("t_s", "op", "pv", "sp", "mv")
    assert data.size == 1000 and data["t_s"][0] == 1000
    # the stiction limit cycle: MV holds still most of the time, a slip starts once OP is fs/12 away
    # and leaves the stem fd/12 behind OP (fs = 250 lbf, fd = 100 lbf): after a reversal OP travels
    # S = (fs + fd)/12 before the stem moves
    slipped = np.diff(data["mv"]) != 0
    assert 0.02 < slipped.mean() < 0.1
    gap_before = np.abs(data["op"][:-1] - data["mv"][:-1])
    gap_after = np.abs(data["op"][:-1] - data["mv"][1:])
    assert np.all(gap_before[slipped] > 250 / 12) and np.all(gap_before[~slipped] <= 250 / 12 + 1e-6)
    np.testing.assert_allclose(gap_after[slipped], 100 / 12, atol=0.01)
    truth = json.loads((tmp_path / "loop.truth.json").read_text())
    assert truth["fs_pct"] == 50 and truth["s_pct"] == pytest.approx(350 / 12)
    assert truth["j_pct"] == pytest.approx(150 / 12)


def test_extension_flags_reach_the_loop(tmp_path):
    out = tmp_path / "q.csv"
    assert main(["simulate", "--case", "C4", "--quantum-pct", "0.5", "--dead-time-s", "2", "--out", str(out)]) == 0
    data = _read(out)
    np.testing.assert_allclose(data["pv"] / 0.5, np.round(data["pv"] / 0.5), atol=1e-6)
    truth = json.loads((tmp_path / "q.truth.json").read_text())
    assert truth["causes"] == ["dead_time", "quantization"]
    assert truth["extensions"] == {"dead_time_s": 2.0, "quantum_pct": 0.5}


def test_a_square_load_reaches_the_loop_and_its_truth(tmp_path):
    from stiction.commands.train import parse_extensions

    out = tmp_path / "sq.csv"
    args = ["simulate", "--fs-pct", "0", "--fd-pct", "0", "--osc-period-s", "120", "--osc-amplitude-pct", "2"]
    assert main([*args, "--osc-shape", "square", "--out", str(out)]) == 0
    assert main([*args, "--out", str(tmp_path / "sine.csv")]) == 0
    truth = json.loads((tmp_path / "sq.truth.json").read_text())
    assert truth["extensions"]["osc_shape"] == "square" and truth["causes"] == ["external_oscillation"]
    assert not np.allclose(_read(out)["pv"], _read(tmp_path / "sine.csv")["pv"], atol=1e-3)
    assert parse_extensions(["osc_period_s=60", "osc_amplitude_pct=1", "osc_shape=triangle"])["osc_shape"] == "triangle"


def test_noisy_case_with_seed_is_reproducible(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    main(["simulate", "--case", "N5", "--seed", "3", "--out", str(a), "--no-truth"])
    main(["simulate", "--case", "N5", "--seed", "3", "--out", str(b), "--no-truth"])
    assert a.read_text() == b.read_text()
    assert not (tmp_path / "a.truth.json").exists()


def test_grid_file_holds_the_training_set(tmp_path):
    out = tmp_path / "grid.npz"
    assert main(["simulate", "--grid", "--out", str(out)]) == 0
    grid = read_grid(out)
    assert grid["op"].shape == (1275, 1000) and grid["op"].dtype == np.float32
    assert grid["fs_pct"][0] == 100 and grid["fd_pct"][0] == 98
    assert grid["meta"]["warmup_s"] == 1000


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["--fs-pct", "20", "--fd-pct", "30"], "fd_pct <= fs_pct"),
        (["--fs-pct", "20"], "needs --fd-pct"),
        (["--case", "C99"], "expected one of"),
        (["--fs-pct", "20", "--fd-pct", "5", "--dead-time-s", "-1"], "dead_time_s"),
        (["--fs-pct", "20", "--fd-pct", "5", "--disturbance", "sine"], "omega"),
        (["--grid", "--out", "grid.csv"], ".npz"),
        (["--fs-pct", "20", "--fd-pct", "5", "--warmup-s", "3000"], "--warmup-s"),
        (["--fs-pct", "20", "--fd-pct", "5", "--osc-shape", "square"], "needs an external oscillation"),
        (["--fs-pct", "20", "--fd-pct", "5", "--valve", "kano", "--actuator-tau-s", "2"], "actuator without lag"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(argv, expected, tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "stiction.cli", "simulate", *argv], capture_output=True, text=True, cwd=tmp_path
    )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and expected in lines[0] and "Traceback" not in done.stderr


def test_every_valve_the_loop_knows_is_a_choice_and_nothing_else():
    """The command keeps its valve choices literal (its start-up imports no compiled loop): held to the loop's."""
    from stiction.cli import build_parser
    from stiction.sim.loop import VALVES

    parser = build_parser()
    for valve in VALVES:
        assert parser.parse_args(["simulate", "--grid", "--valve", valve]).valve == valve
    with pytest.raises(SystemExit):
        parser.parse_args(["simulate", "--grid", "--valve", "choudhury"])
