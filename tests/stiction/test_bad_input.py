"""Every command's help and a table of bad inputs: exit 0 with a sensible answer, or exit 2 with one
line naming the file, row or field; never a traceback, never an internal error."""

import json

import numpy as np
import pytest

from stiction.cli import COMMANDS, build_parser, main


def _subcommands():
    parser = build_parser()
    out = [[name] for name in COMMANDS]
    bench = next(a for a in parser._subparsers._group_actions[0].choices["bench"]._actions if a.dest == "bench")
    out += [["bench", name] for name in bench.choices]
    return out


@pytest.mark.parametrize("argv", _subcommands(), ids=" ".join)
def test_every_help_prints_and_exits_0(argv, capsys):
    with pytest.raises(SystemExit) as done:
        main([*argv, "--help"])
    assert done.value.code == 0
    out = capsys.readouterr().out
    assert "usage: stiction" in out
    if len(argv) == 1:  # every command shows one line a user can copy
        assert f"example:\n  stiction {argv[0]} " in out


def test_version_prints_the_installed_version(capsys):
    from importlib.metadata import version

    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0 and capsys.readouterr().out.strip() == f"stiction {version('stiction')}"


def _loop_csv(path, n=1500, pv=None, op=None, sep=",", decimal="."):
    t = np.arange(n) * 1.0
    op = 50 + 5 * np.sign(np.sin(t / 40)) * np.minimum(1, np.abs(np.sin(t / 40)) * 3) if op is None else op
    pv = 50 + 3 * np.sin(t / 40 + 1) + 0.05 * np.random.default_rng(0).standard_normal(n) if pv is None else pv
    text = f"t{sep}op{sep}pv\n" + "".join(
        f"{a:.1f}{sep}{b:.10g}{sep}{c:.10g}\n".replace(".", decimal) for a, b, c in zip(t, op, pv, strict=True)
    )
    path.write_text(text)
    return path


def _one_line_error(capsys, argv, *expected):
    code = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) >= 1 and all("Traceback" not in e and "internal error" not in e for e in err), err
    assert all(x in err[0] for x in expected), err
    return err


def test_a_text_file_named_parquet_is_read_by_its_content(tmp_path, capsys):
    (tmp_path / "x.parquet").write_text("hello\nworld\n")
    _one_line_error(capsys, ["quantify", str(tmp_path / "x.parquet")], "x.parquet", "one column")
    (tmp_path / "bad.parquet").write_bytes(b"PAR1" + bytes(range(256)) * 4)
    _one_line_error(capsys, ["quantify", str(tmp_path / "bad.parquet")], "bad.parquet", "not a readable Parquet")
    csv_named_parquet = _loop_csv(tmp_path / "loop.parquet")
    assert main(["quantify", "--json", str(csv_named_parquet)]) == 0
    assert json.loads(capsys.readouterr().out)["loop_id"] == "loop"


def test_simulate_out_to_a_missing_folder_or_a_folder(tmp_path, capsys):
    base = ["simulate", "--fs-pct", "50", "--fd-pct", "20", "--duration-s", "300", "--warmup-s", "0"]
    _one_line_error(capsys, [*base, "--out", str(tmp_path / "no" / "x.csv")], "no folder")
    _one_line_error(capsys, [*base, "--out", str(tmp_path)], "is a directory")


def test_separators_and_decimal_commas_read_as_the_same_loop(tmp_path, capsys):
    plain = _loop_csv(tmp_path / "plain.csv")
    semi = _loop_csv(tmp_path / "semi.csv", sep=";", decimal=",")
    tab = _loop_csv(tmp_path / "tab.csv", sep="\t")
    assert main(["quantify", "--json", str(plain), str(semi), str(tab)]) == 0
    reports = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [r["loop_id"] for r in reports] == ["plain", "semi", "tab"]
    assert reports[0]["period_s"] == pytest.approx(reports[1]["period_s"], rel=1e-3)
    assert reports[0]["period_s"] == pytest.approx(reports[2]["period_s"], rel=1e-9)


def test_a_folder_is_read_as_the_exports_in_it(tmp_path, capsys):
    folder = tmp_path / "plant"
    folder.mkdir()
    _loop_csv(folder / "a.csv")
    _loop_csv(folder / "b.csv")
    (folder / "notes.md").write_text("not an export")
    assert main(["quantify", "--json", str(folder)]) == 0
    assert [json.loads(x)["loop_id"] for x in capsys.readouterr().out.splitlines()] == ["a", "b"]
    (tmp_path / "empty").mkdir()
    _one_line_error(capsys, ["quantify", str(tmp_path / "empty")], "empty", "no exports")


@pytest.mark.parametrize("command", ["quantify", "diagnose"])
def test_a_short_file_is_named_by_its_file(tmp_path, capsys, command):
    short = _loop_csv(tmp_path / "short.csv", n=20)
    _one_line_error(capsys, [command, str(short)], "short.csv", "20 samples")


@pytest.mark.parametrize("command", ["quantify", "diagnose"])
def test_a_stretch_a_gap_left_too_short_is_named_with_the_gap(tmp_path, capsys, command):
    # 150 samples, 50 s missing after the 80th: neither stretch holds the 100 samples a reading needs
    n = 200
    path = _loop_csv(tmp_path / "gapped.csv", n=n)
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join(lines[:81] + lines[131:]))
    _one_line_error(capsys, [command, str(path)], "gapped.csv", "80 samples, need at least",
                    "1 gap in the time column at row 82 (a step of 51 s")  # fmt: skip


def test_a_dead_sensor_gets_no_numbers_and_says_why(tmp_path, capsys):
    flat = _loop_csv(tmp_path / "flat.csv", pv=np.full(1500, 3.5e-44))
    assert main(["quantify", "--json", str(flat)]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["fs_pct"] is None and r["s_pct"] is None and r["method"] == "none"
    assert r["thesis"]["fs_pct"] is None and r["learned"]["fs_pct"] is None and r["physical"] is None
    assert any("PV does not move" in w for w in r["warnings"])
    assert main(["diagnose", "--json", str(flat)]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["s_pct"] is None and any("PV does not move" in w for w in d["warnings"])


def test_a_controller_in_manual_gets_no_numbers(tmp_path, capsys):
    manual = _loop_csv(tmp_path / "manual.csv", op=np.full(1500, 42.0))
    assert main(["quantify", "--json", str(manual)]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["fs_pct"] is None and any("manual" in w for w in r["warnings"])


def test_the_physical_block_is_null_when_the_process_is_not_declared(tmp_path, capsys):
    assert main(["quantify", "--json", str(_loop_csv(tmp_path / "a.csv"))]) == 0
    assert json.loads(capsys.readouterr().out)["physical"] is None


def test_values_no_percent_can_have_are_refused(tmp_path, capsys):
    huge = _loop_csv(tmp_path / "huge.csv", pv=np.full(1500, 1e308))
    _one_line_error(capsys, ["quantify", str(huge)], "huge.csv", "row 2", "column 'pv'", "percent of span")


def test_every_gives_one_report_per_window_naming_its_rows(tmp_path, capsys):
    loop = _loop_csv(tmp_path / "a.csv", n=1500)
    assert main(["quantify", "--json", "--last", "1000", "--every", "250", str(loop)]) == 0
    reports = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    assert [r["t_end_s"] for r in reports] == [999.0, 1249.0, 1499.0]  # the last ends at the file end
    assert any("rows 502-1501 of the file" in w for w in reports[2]["warnings"])


def test_one_bad_file_never_stops_the_others(tmp_path, capsys):
    good = _loop_csv(tmp_path / "good.csv")
    (tmp_path / "bad.csv").write_text("t,op,pv\n0,1,2\n0,1,2\n")
    code = main(["quantify", "--json", str(tmp_path / "bad.csv"), str(good)])
    out, err = capsys.readouterr()
    assert code == 2 and "bad.csv: row 3: time 0 repeats" in err
    assert json.loads(out)["loop_id"] == "good"


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["quantify", "--last", "5", "x.csv"], "--last 5"),
        (["quantify", "--every", "0", "x.csv"], "--every 0"),
        (["quantify", "--pv-span", "100", "0", "x.csv"], "--pv-span 100 0"),
        (["diagnose", "--pv-span", "0", "nan", "x.csv"], "--pv-span 0 nan"),
        (["diagnose", "--max-causes", "-1", "x.csv"], "--max-causes -1"),
        (["quantify", "nope.csv"], "nope.csv: no such file"),
        (["agent", "--estimate-every", "0"], "--estimate-every at least 1"),
        (["agent", "--first-window", "50"], "at least 100 samples"),
        (["bench", "detect", "--samples", "10"], "--samples 10: need at least 100"),
        (["bench", "detect", "--network-draws", "0"], "--network-draws 0: need at least 1"),
        (["bench", "bridge", "--rate", "-1"], "--loops, --seconds and --rate must be positive"),
    ],
)
def test_bad_flags_and_paths(capsys, argv, expected):
    _one_line_error(capsys, argv, expected)


def test_bench_json_prints_one_object_and_the_text_its_table(capsys):
    argv = ["bench", "sim", "--reference-loops", "1", "--repeats", "1", "--no-agreement", "--duration-s", "200"]
    assert main([*argv, "--json"]) == 0
    figures = json.loads(capsys.readouterr().out)
    assert isinstance(figures, dict) and figures["duration_s"] == 200 and figures["host"]["cpu"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "fast simulator" in text and "ODE reference" in text and "speedup" in text


def test_the_demo_table_says_how_many_loops_it_leaves_out():
    from types import SimpleNamespace

    from stiction.commands.demo import _table

    truths = {f"loop{k:02d}": SimpleNamespace(fs_pct=10.0, fd_pct=5.0, disturbance=None) for k in range(40)}
    text = _table({}, truths, 16, 1.0, 0, 40)
    assert sum(line.startswith("loop") and not line.startswith("loop ") for line in text.splitlines()) == 16
    assert "showing 16 of 40 loops" in text


LOOPS_TOML = '[loops.A]\nop = "ns=2;s=A.OP"\npv = "ns=2;s=A.PV"\n'


@pytest.mark.parametrize(
    ("loop_file", "flags", "expected"),
    [
        ('[loops.A]\nop = "A.OP"\npv = "ns=2;s=A.PV"\n', [], "loops.A.op: expected an OPC UA node id"),
        ("loops = [", [], "not valid TOML"),
        (LOOPS_TOML, [], "no OPC UA endpoint"),
        (LOOPS_TOML, ["--endpoint", "http://plant:4840"], "expected opc.tcp://"),
        (
            LOOPS_TOML,
            ["--endpoint", "opc.tcp://127.0.0.1:1", "--user", "bob", "--password-env", "NO_SUCH_VAR_X"],
            "no password in the environment variable NO_SUCH_VAR_X",
        ),  # fmt: skip
        (LOOPS_TOML, ["--endpoint", "opc.tcp://127.0.0.1:1", "--bridge-id", "a/b"], "bridge id 'a/b'"),
        (LOOPS_TOML, ["--endpoint", "opc.tcp://127.0.0.1:1", "--rate", "0"], "--rate 0: messages per second"),
        (LOOPS_TOML, ["--endpoint", "opc.tcp://127.0.0.1:1", "--rate", "nan"], "--rate nan: messages per second"),
    ],
)
def test_the_bridge_answers_a_bad_loop_file_or_flag_with_one_line(tmp_path, capsys, loop_file, flags, expected):
    (f := tmp_path / "loops.toml").write_text(loop_file)
    _one_line_error(capsys, ["bridge", "opcua", "--loop-file", str(f), *flags], expected)


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["plant", "--endpoint", "tcp/127.0.0.1:4840"], "expected opc.tcp://"),
        (["plant", "--loops", "0"], "--loops and --speed must be positive"),
        (["plant", "--loop-file", "/no/such/dir/loops.toml"], "no such directory"),
        (["replay", "--speed", "0", "x.csv"], "--speed and --rate must be positive"),
        (["replay", "nope.csv"], "nope.csv: no such file"),
        (["replay", "--wait", "nan", "x.csv"], "--wait must be 0 or more seconds"),
    ],
)
def test_plant_and_replay_answer_bad_flags_with_one_line(capsys, argv, expected):
    _one_line_error(capsys, argv, expected)


def test_every_bench_subcommand_has_its_runner():
    import argparse

    from stiction.commands import bench

    parser = argparse.ArgumentParser()
    bench.add_arguments(parser)
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert set(sub.choices) == set(bench.BENCHMARKS)


def test_pv_in_engineering_units_reads_as_the_same_loop_given_its_span(tmp_path, capsys):
    """Hidden effect: the same loop exported with PV over a transmitter range of 200-700 (kg/h, say);
    with ``--pv-span 200 700`` it reads as the percent export does, gain and all."""
    n = 1500
    t = np.arange(n) * 1.0
    op = 50 + 5 * np.sign(np.sin(t / 40)) * np.minimum(1, np.abs(np.sin(t / 40)) * 3)
    pv = 50 + 3 * np.sin(t / 40 + 1) + 0.05 * np.random.default_rng(0).standard_normal(n)
    plain = _loop_csv(tmp_path / "pct.csv", n, pv=pv, op=op)
    units = _loop_csv(tmp_path / "kgh.csv", n, pv=200 + 5 * pv, op=op)
    reports = []
    for path, flags in ((plain, []), (units, ["--pv-span", "200", "700"]), (units, [])):
        assert main(["quantify", "--json", *flags, str(path)]) == 0
        reports.append(json.loads(capsys.readouterr().out))
    same, scaled, raw = reports
    assert scaled["verdict"] == same["verdict"] and scaled["regularity"] == pytest.approx(same["regularity"], rel=1e-6)
    assert scaled["amplitude_pct"] == pytest.approx(same["amplitude_pct"], rel=1e-6)
    assert raw["amplitude_pct"] == pytest.approx(5 * same["amplitude_pct"], rel=1e-6)  # read as percent: 5x
    assert any("--pv-span" in w for w in raw["warnings"]) and any("200-700" in w for w in scaled["warnings"])
