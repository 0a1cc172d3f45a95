"""``stiction bench measured`` says what each loop cost to diagnose, and which was slowest."""


import pytest

from stiction.bench.measured import bench_measured, print_summary
from tests.measured import PLANT


def test_each_loop_carries_its_cpu_seconds_and_the_summary_names_the_slowest(capsys):
    files = sorted(PLANT.glob("stic_2111FIC46002_*.csv"))[:1] + sorted(PLANT.glob("stic_2411FIC20102_*.csv"))[:1]
    if len(files) < 2:
        pytest.skip("measured plant data not here")
    fig = bench_measured(files, workers=1)
    seconds = [row["cpu_s"] for row in fig["rows"]]
    assert len(seconds) == 2 and all(s > 0 for s in seconds)
    s = fig["summary"]
    assert s["cpu_s_max"] == max(seconds) and min(seconds) <= s["cpu_s_median"] <= max(seconds)
    assert s["slowest"] == files[seconds.index(max(seconds))].name
    print_summary(fig)
    assert f"largest {max(seconds):.1f} ({s['slowest']})" in capsys.readouterr().out


def test_a_folder_without_exports_is_named_not_benched_as_zero_loops(tmp_path):
    from stiction.schemas.errors import InputError

    (tmp_path / "csv").mkdir()
    with pytest.raises(InputError, match="no CSV export here"):
        bench_measured([tmp_path], workers=1)


def test_a_loop_that_cannot_be_diagnosed_is_named_and_the_others_are_benched(tmp_path, capsys):
    """One export the diagnosis cannot read (here a file of three rows) is that loop's one line, not the run's end:
    a defect on one measured loop (a NaN in a fit) once stopped the whole table."""
    from stiction.sim.export import write_csv
    from stiction.sim.loop import LoopSpec, simulate

    good = tmp_path / "good.csv"
    write_csv(good, simulate([LoopSpec(30.0, 10.0)]).kept())
    bad = tmp_path / "bad.csv"
    bad.write_text("t,op,pv\n0,1,2\n1,1,2\n2,1,2\n")
    fig = bench_measured([bad, good], workers=1)
    assert [row["file"] for row in fig["rows"]] == [str(good)]
    (fail,) = fig["summary"]["failed"]
    assert fail["file"] == "bad.csv" and fail["error"] and "\n" not in fail["error"]
    print_summary(fig)
    assert "not diagnosed: bad.csv: " in capsys.readouterr().out
