"""``stiction quantify`` as a user runs it."""

import json
import subprocess
import sys

import pytest

from stiction.cli import main


@pytest.fixture(scope="module")
def loops(tmp_path_factory):
    d = tmp_path_factory.mktemp("loops")
    main(["simulate", "--fs-pct", "50", "--fd-pct", "20", "--out", str(d / "a.csv")])
    main(["simulate", "--case", "N1", "--seed", "2", "--out", str(d / "n1.csv")])
    (d / "bad.csv").write_text("t,op,pv\n0,1,2\n1,x,2\n")
    return d


def test_json_lines_one_report_per_file(loops, capsys):
    assert main(["quantify", "--json", "--process", "level", str(loops / "a.csv"), str(loops / "n1.csv")]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    reports = [json.loads(line) for line in lines]
    assert [r["loop_id"] for r in reports] == ["a", "n1"]
    assert reports[0]["method"] == "physical"
    assert reports[0]["fs_pct"] == pytest.approx(50, abs=0.1) and reports[0]["fd_pct"] == pytest.approx(20, abs=0.1)
    # N1's noise hides the slips from PV's steps: the command fits the valve to the record (ident.open_loop)
    from stiction.quantify.pipeline import FITTED_WARNING
    from stiction.sim.grid import case_specs

    n1 = case_specs(seed=2)["N1"]
    assert reports[1]["denoised"] and reports[1]["method"] == "physical" and FITTED_WARNING in reports[1]["warnings"]
    assert abs(reports[1]["fs_pct"] - n1.fs_pct) <= 2 * reports[1]["fs_se_pct"]
    assert abs(reports[1]["fd_pct"] - n1.fd_pct) <= 2 * reports[1]["fd_se_pct"]


def test_bad_file_is_named_and_the_others_still_reported(loops):
    done = subprocess.run(
        [sys.executable, "-m", "stiction.cli", "quantify", "--json", str(loops / "bad.csv"), str(loops / "a.csv")],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2
    assert "bad.csv: row 3, column 'op': 'x' is not a number" in done.stderr and "Traceback" not in done.stderr
    assert json.loads(done.stdout)["loop_id"] == "a"


def test_a_fault_of_ours_in_one_file_is_named_and_the_others_still_reported(loops, capsys, monkeypatch):
    from stiction.quantify.pipeline import Quantifier

    real = Quantifier.results

    def failing_on_n1(self, windows, **kw):
        if windows[0].loop_id == "n1":
            raise ValueError("zero-size array to reduction operation maximum")
        return real(self, windows, **kw)

    monkeypatch.setattr(Quantifier, "results", failing_on_n1)
    assert main(["quantify", "--json", str(loops / "n1.csv"), str(loops / "a.csv")]) == 2
    out, err = capsys.readouterr()
    assert [json.loads(line)["loop_id"] for line in out.strip().splitlines()] == ["a"]
    assert "n1.csv: internal error (ValueError: zero-size array" in err and "Traceback" not in err


def test_readable_summary_names_the_process_it_identified(loops, capsys):
    assert main(["quantify", str(loops / "a.csv")]) == 0
    out = capsys.readouterr().out
    assert "fs 50.0 %" in out and "thesis chain" in out and "method physical" in out
    assert "identified from the record: the thesis's level loop" in out


def test_plot_writes_one_png_per_loop_that_is_not_blank(loops, tmp_path, capsys):
    import matplotlib.image as mpimg

    out = tmp_path / "plots"
    assert main(["quantify", "--plot", str(out), str(loops / "a.csv"), str(loops / "n1.csv")]) == 0
    pngs = sorted(out.glob("*.png"))
    assert [p.name for p in pngs] == ["a.png", "n1.png"]
    for p in pngs:
        img = mpimg.imread(p)
        assert img.shape[0] > 300 and img.shape[1] > 800
        assert img[..., :3].std() > 0.05  # lines and points, not an empty canvas


def test_rank_puts_the_sticky_valve_first_and_the_dead_sensor_last(loops, tmp_path, capsys):
    import numpy as np

    from stiction.sim.plant_loops import plant_loops, simulate_plant, stable

    plant = tmp_path / "plant"
    plant.mkdir()
    main(["simulate", "--fs-pct", "60", "--fd-pct", "20", "--out", str(plant / "sticky.csv")])
    external = next(
        (r for loop, r in zip(plant_loops(6, 5), simulate_plant(plant_loops(6, 5)), strict=True)
         if loop.cause == "external_oscillation" and stable(r[0], r[1])))  # fmt: skip
    op, pv, sp, ts_s = external
    t = np.arange(op.size) * ts_s
    np.savetxt(plant / "load.csv", np.c_[t, op, pv, sp], delimiter=",", header="t,op,pv,sp", comments="")
    np.savetxt(plant / "dead.csv", np.c_[t, op, np.full(op.size, 3.5e-44)], delimiter=",", header="t,op,pv",
               comments="")  # fmt: skip
    out_csv = tmp_path / "ranked.csv"
    assert main(["quantify", str(plant), "--rank", "--csv", str(out_csv)]) == 0
    printed = capsys.readouterr().out
    rows = out_csv.read_text().splitlines()
    assert rows[0].startswith("rank,loop,verdict")
    order = [line.split(",")[1] for line in rows[1:]]
    verdicts = {line.split(",")[1]: line.split(",")[2] for line in rows[1:]}
    assert order[0] == "sticky" and verdicts["sticky"] == "stiction"
    assert order[-1] == "dead" and verdicts["dead"] == "bad_data"
    assert verdicts["load"] != "stiction"
    assert "3 loops: 1 stiction" in printed
    # the dead sensor's summary says that nothing was read rather than printing a line of dashes
    assert main(["quantify", str(plant / "dead.csv")]) == 0
    summary = capsys.readouterr().out
    assert "verdict bad data" in summary and "S, J: not read (the warnings say why)" in summary
    assert "- +- -" not in summary


def test_csv_without_rank_is_refused(loops, capsys):
    assert main(["quantify", str(loops / "a.csv"), "--csv", "x.csv"]) == 2
    assert "--csv FILE goes with --rank" in capsys.readouterr().err


def test_a_long_plant_export_is_sized_once_in_size_every_minutes_of_data_and_carried_between(tmp_path, capsys):
    import numpy as np

    from stiction.sim.plant_loops import plant_loops, simulate_plant

    loop = [x for x in plant_loops(8, 2027) if x.cause == "stiction"][6]  # first order, sampled every 5 s
    op, pv, sp, ts_s = simulate_plant([loop], samples=3000)[0]
    t = np.arange(op.size) * ts_s
    np.savetxt(tmp_path / "fic.csv", np.c_[t, op, pv, sp], delimiter=",", header="t,op,pv,sp", comments="")
    argv = ["quantify", str(tmp_path / "fic.csv"), "--every", "600", "--last", "600", "--json"]
    assert main([*argv, "--size-every", "100"]) == 0  # 6000 s of data between sizings; windows of 3000 s
    reports = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    sized = [r for r in reports if r["method"] == "identified"]
    fresh = [r for r in sized if r["estimate_t_end_s"] == r["t_end_s"]]
    carried = [r for r in sized if r["estimate_t_end_s"] < r["t_end_s"]]
    assert len(fresh) >= 2 and len(carried) >= 1
    assert all(b["t_end_s"] - a["t_end_s"] >= 6000 for a, b in zip(fresh[:-1], fresh[1:], strict=True))
    for r in carried:
        source = next(f for f in fresh if f["t_end_s"] == r["estimate_t_end_s"])
        assert r["s_pct"] == source["s_pct"] and any("earlier window" in w for w in r["warnings"])
    for r in sized:
        assert abs(r["s_pct"] - loop.s_pct) <= 2 * r["s_se_pct"]
    assert main([*argv, "--no-identify"]) == 0
    assert all(json.loads(line)["method"] == "none" for line in capsys.readouterr().out.splitlines())


def test_sizing_on_worker_processes_gives_the_same_reports_in_the_same_order(tmp_path, capsys):
    import numpy as np

    from stiction.sim.plant_loops import plant_loops, simulate_plant, stable

    loops = [x for x in plant_loops(8, 2027) if x.cause == "stiction"]
    for i, (op, pv, sp, ts_s) in enumerate(simulate_plant(loops)):
        if stable(op, pv):
            t = np.arange(op.size) * ts_s
            np.savetxt(tmp_path / f"p{i}.csv", np.c_[t, op, pv, sp], delimiter=",", header="t,op,pv,sp", comments="")
    (tmp_path / "broken.csv").write_text("op,pv\n1,2\n")
    out = {}
    for jobs in ("1", "2"):
        assert main(["quantify", str(tmp_path), "--json", "--jobs", jobs]) == 2  # the broken file, named
        out[jobs] = capsys.readouterr()
    assert out["1"].out == out["2"].out and "broken.csv" in out["2"].err
    reports = [json.loads(line) for line in out["2"].out.splitlines()]
    assert len(reports) == len(list(tmp_path.glob("p*.csv"))) and any(r["method"] == "identified" for r in reports)


def _columns(path, keep, rename=None):
    """The export at ``path`` with only the columns ``keep`` (in that order), ``rename`` mapping a kept column to a
    source column's values (an ``mv`` that repeats ``op``)."""
    import csv

    rows = list(csv.DictReader(path.open()))
    rename = rename or {}
    return "\n".join([",".join(keep)] + [",".join(r[rename.get(k, k)] for k in keep) for r in rows]) + "\n"


@pytest.fixture(scope="module")
def flow(tmp_path_factory):
    """A fast flow loop under a slow PI and a wandering load, its valve of S 2.9 %, J 0.42 % (fs 4, fd 3): the
    stem slips now and then, no cycle forms; the export records the stem position (``mv``) as ``simulate`` writes."""
    d = tmp_path_factory.mktemp("flow")
    main(["simulate", "--fs-pct", "4", "--fd-pct", "3", "--process-gain", "1", "--process-tau-s", "5", "--kc", "0.3",
          "--ti-s", "20", "--disturbance", "brownian", "--coefficient", "0.5", "--seed", "1", "--duration-s", "3600",
          "--out", str(d / "with_mv.csv")])  # fmt: skip
    source = d / "with_mv.csv"
    (d / "without_mv.csv").write_text(_columns(source, ["t_s", "op", "pv", "sp"]))
    (d / "mv_is_op.csv").write_text(_columns(source, ["t_s", "op", "pv", "sp", "mv"], rename={"mv": "op"}))
    main(["simulate", "--fs-pct", "0", "--fd-pct", "0", "--process-gain", "1", "--process-tau-s", "5", "--kc", "0.3",
          "--ti-s", "20", "--osc-period-s", "120", "--osc-amplitude-pct", "2", "--seed", "2", "--duration-s", "3600",
          "--out", str(d / "healthy.csv")])  # fmt: skip
    return d


def _reports(capsys, *paths):
    assert main(["quantify", "--json", *map(str, paths)]) == 0
    return [json.loads(line) for line in capsys.readouterr().out.strip().splitlines()]


def test_a_measured_stem_that_sticks_calls_the_valve_and_gives_its_band(flow, capsys):
    from stiction.sim.valve import band_and_jump_pct

    s_true, j_true = (float(v) for v in band_and_jump_pct(4.0, 3.0))
    with_mv, without = _reports(capsys, flow / "with_mv.csv", flow / "without_mv.csv")
    assert with_mv["verdict"] == "stiction" and with_mv["likely_cause"] == "stiction"
    assert any(w.startswith("the measured stem (mv) sticks") for w in with_mv["warnings"])
    assert abs(with_mv["s_pct"] - s_true) <= 2 * with_mv["s_se_pct"] and with_mv["s_se_pct"] < 0.5 * s_true
    assert abs(with_mv["j_pct"] - j_true) <= 2 * with_mv["j_se_pct"]
    assert not any("stem" in w for w in without["warnings"])  # no stem recorded: OP and PV alone
    if without["verdict"] != "stiction":  # the stem saw what the loop did not: its verdict and numbers speak
        assert with_mv["method"] == "stem" and any("OP and PV alone said" in w for w in with_mv["warnings"])
        assert not any(w.startswith("no friction numbers") for w in with_mv["warnings"])


def test_a_stem_that_follows_op_leaves_the_verdict_to_op_and_pv_and_an_mv_that_is_op_is_no_stem(flow, capsys):
    healthy, mv_is_op, without = _reports(capsys, flow / "healthy.csv", flow / "mv_is_op.csv", flow / "without_mv.csv")
    assert healthy["verdict"] != "stiction" and healthy["method"] != "stem"
    assert any(w.startswith("the measured stem (mv) follows OP") for w in healthy["warnings"])
    assert any("repeats OP" in w for w in mv_is_op["warnings"])
    assert mv_is_op["verdict"] == without["verdict"] and mv_is_op["s_pct"] == without["s_pct"]
