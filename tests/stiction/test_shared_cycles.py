"""Plant triage's shared cycles (``stiction.ranking.shared_cycles``): loops that cycle with one period over the same
hours are named together, the one whose own valve reads stickiest first."""

from stiction.ranking import shared_cycles
from stiction.schemas.report import Estimate, ProcessInfo, StictionReport

DAY = 1.7e9  # a calendar time (seconds since 1970)


def _report(loop_id, verdict="other_cause", period_s=150.0, p=0.2, t_end_s=DAY, n=3600, ts_s=1.0):
    none = Estimate(fs_pct=None, fd_pct=None)
    return StictionReport(
        loop_id=loop_id, verdict=verdict, stiction_probability=p, likely_cause="stiction", regularity=5.0,
        amplitude_pct=1.0, process=ProcessInfo(kind="unknown", source="none", sample_time_s=ts_s), fs_pct=None,
        fd_pct=None, s_pct=None, j_pct=None, s_se_pct=None, j_se_pct=None, fs_se_pct=None, fd_se_pct=None,
        period_s=period_s, denoised=False, method="none", thesis=none, physical=None, learned=none, ood_score=None,
        explained=None, oscillating=period_s is not None, warnings=[], model_version="test", n_samples=n,
        t_end_s=t_end_s,
    )  # fmt: skip


def test_loops_of_one_period_over_the_same_hours_are_one_group_whose_stickiest_valve_is_named():
    reports = [
        _report("FIC101", "stiction", 150.0, p=0.9),
        _report("LIC102", "stiction", 154.0, p=0.6),  # 3 % longer: the same cycle read downstream
        _report("PIC103", "other_cause", 148.0, t_end_s=DAY + 1800),  # half an hour later: half the hour shared
        _report("FIC104", "other_cause", 300.0),  # another period
        _report("FIC105", "stiction", 150.0, p=0.95, t_end_s=DAY - 86400),  # the day before
        _report("TIC106", "no_oscillation", 150.0),  # no cycle to share
    ]
    (g,) = shared_cycles(reports)
    assert g.loop_ids == ("FIC101", "LIC102", "PIC103") and g.source == "FIC101"
    assert 148 <= g.period_s <= 154 and "fix it first" in g.text() and "FIC101's valve" in g.text()


def test_neighbouring_periods_do_not_chain_and_records_without_calendar_time_are_grouped_with_none():
    chain = [_report(f"L{k}", period_s=100.0 * 1.04**k) for k in range(6)]  # each 4 % past the one before
    groups = shared_cycles(chain)
    assert all(max(r.period_s for r in chain if r.loop_id in g.loop_ids)
               <= 1.05 * min(r.period_s for r in chain if r.loop_id in g.loop_ids) for g in groups)  # fmt: skip
    assert len(groups) == 3 and all(g.source is None and "look upstream" in g.text() for g in groups)
    assert shared_cycles([_report("A", t_end_s=3599.0), _report("B", t_end_s=3599.0)]) == []  # stamped from zero
    assert shared_cycles([_report("A")]) == []


def _in_calendar_time(path):
    """The export's times as a historian stamps them: seconds since 1970, the same hours for every file."""
    lines = path.read_text().splitlines()
    rows = [line.split(",") for line in lines[1:]]
    path.write_text("\n".join([lines[0]] + [",".join([f"{DAY + float(r[0]):.0f}", *r[1:]]) for r in rows]) + "\n")


def test_rank_names_a_downstream_loop_that_carries_an_upstream_sticky_valves_cycle(tmp_path, capsys):
    """A sticky valve's loop, and a healthy loop downstream under a square load of its period (what a sticky valve
    upstream sends): the triage names them together, the sticky one to fix first."""
    import json

    from stiction.cli import main

    main(["simulate", "--fs-pct", "30", "--fd-pct", "20", "--seed", "5", "--out", str(tmp_path / "up.csv")])
    _in_calendar_time(tmp_path / "up.csv")
    capsys.readouterr()
    assert main(["quantify", "--json", "--no-identify", str(tmp_path / "up.csv")]) == 0
    period = json.loads(capsys.readouterr().out)["period_s"]
    main(["simulate", "--fs-pct", "0", "--fd-pct", "0", "--osc-period-s", f"{period:.1f}", "--osc-amplitude-pct", "3",
          "--osc-shape", "square", "--seed", "6", "--out", str(tmp_path / "down.csv")])  # fmt: skip
    _in_calendar_time(tmp_path / "down.csv")
    capsys.readouterr()
    assert main(["quantify", "--rank", "--no-identify", "--csv", str(tmp_path / "rank.csv"), str(tmp_path)]) == 0
    out = capsys.readouterr().out
    (line,) = [x for x in out.splitlines() if x.startswith("shared cycle")]
    assert "down, up cycle at about" in line and "up's valve reads stickiest" in line
    rows = (tmp_path / "rank.csv").read_text().splitlines()
    assert "shared_cycle" in rows[0] and all(",1," in row for row in rows[1:])
