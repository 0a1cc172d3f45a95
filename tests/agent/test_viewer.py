"""The rerun sink: a recording read back with rerun's own API has the entities and rows it should."""

from collections import Counter

import pytest

rr = pytest.importorskip("rerun")

from stiction.agent.viewer import ENTITIES, RerunSink, blueprint, path  # noqa: E402
from stiction.quantify.pipeline import Window  # noqa: E402
from stiction.sim.grid import case_specs  # noqa: E402
from stiction.sim.loop import simulate  # noqa: E402


def _record(file, quantifier, reports_per_loop=3, window=300, step=100, **sink_kw):
    specs = case_specs(seed=1)
    names = ["C4", "N4"]
    r = simulate([specs[n] for n in names], duration_s=1000 + window + step * reports_per_loop).kept()
    sink = RerunSink(f"save:{file}", **sink_kw)
    estimates: Counter[str] = Counter()  # reports that carry an estimate (a window not called sticky has none)
    for k in range(reports_per_loop):
        end = window + k * step
        windows = [
            Window(n, r.op[i, end - window : end], r.pv[i, end - window : end], 1.0, float(r.t_s[end - 1]), "level")
            for i, n in enumerate(names)
        ]
        for w, (report, details) in zip(windows, quantifier.quantify_with_details(windows), strict=True):
            truth = (specs[w.loop_id].fs_pct, specs[w.loop_id].fd_pct) if w.loop_id == "C4" else None
            sink.log_report(report, w, details, truth)
            estimates[w.loop_id] += report.fs_pct is not None
            if "clock" in sink_kw:
                sink_kw["clock"].advance()
    sink.close()
    rows: Counter[str] = Counter()
    for chunk in rr.chunk.RrdReader(file).stream().to_chunks():
        if not chunk.is_static:
            rows[chunk.entity_path.lstrip("/")] += chunk.num_rows
    return names, rows, estimates


def test_recording_holds_every_loops_views_with_one_row_per_report(tmp_path, quantifier_fixture):
    reports_per_loop, window, step = 3, 300, 100
    full = {"min_cloud_interval_s": 0, "max_cloud_points": 10**9, "max_series_points": 10**9}
    names, rows, _ = _record(tmp_path / "rec.rrd", quantifier_fixture, reports_per_loop, window, step, **full)
    for name in names:
        for what in ("raw", "clean", "fs_est", "fd_est"):
            assert rows[path(name, what)] == reports_per_loop, (name, what)
        assert 1 <= rows[path(name, "curve")] <= reports_per_loop  # logged again only where it moved
        assert 1 <= rows[path(name, "flags")] <= reports_per_loop  # and the flags where they changed
        # history goes in once: every sample of every window, no repeats
        assert rows[path(name, "op")] == rows[path(name, "pv")] == window + (reports_per_loop - 1) * step
    assert rows[path("C4", "fs_true")] == 1 and path("N4", "fs_true") not in rows  # the truth where it changes
    assert set(ENTITIES) >= {"raw", "curve", "clean"}


class _Clock:
    def __init__(self, step_s):
        self.t, self.step_s = 0.0, step_s

    def __call__(self):
        return self.t

    def advance(self):
        self.t += self.step_s


def test_a_kept_recording_thins_points_and_rate_limits_the_clouds(tmp_path, quantifier_fixture):
    full = {"min_cloud_interval_s": 0, "max_cloud_points": 10**9, "max_series_points": 10**9}
    _, rows_full, _ = _record(tmp_path / "full.rrd", quantifier_fixture, 20, 300, 50, **full)
    # 20 reports a loop, one every 0.4 s of wall clock (two loops, one tick each): clouds at most every 5 s
    names, rows, estimates = _record(tmp_path / "kept.rrd", quantifier_fixture, 20, 300, 50, clock=_Clock(0.2))
    for name in names:
        assert rows[path(name, "fs_est")] == estimates[name] >= 18  # every estimate kept (a sticky loop's)
        assert rows[path(name, "raw")] == rows[path(name, "clean")] == 2  # at 0 s and 5.2 s of the 7.6 s
        assert rows[path(name, "op")] == rows[path(name, "pv")] == (300 + 19 * 50) // 10  # every 10th sample
    kept, whole = (tmp_path / "kept.rrd").stat().st_size, (tmp_path / "full.rrd").stat().st_size
    assert kept < whole / 2, (kept, whole)
    assert sum(rows_full.values()) > sum(rows.values())


def test_blueprint_has_an_overview_and_a_detail_tab():
    bp = blueprint([f"L{i}" for i in range(20)], detail_loop="L3")
    tabs = bp.root_container.contents
    assert len(tabs) == 2
    assert len(tabs[0].contents) == 16  # the overview shows at most 16 loops


def test_bad_mode_is_refused():
    with pytest.raises(ValueError, match="save:PATH"):
        RerunSink("record")


@pytest.fixture(scope="module")
def quantifier_fixture():
    from stiction.quantify.pipeline import Quantifier

    return Quantifier()


def test_a_window_without_a_cycle_shows_its_points_and_no_curve(tmp_path, quantifier_fixture):
    """The same loop oscillating, then not (the report says so), then oscillating again: the curve is
    logged, cleared once, and logged again; the raw points every time."""
    specs = case_specs(seed=1)
    r = simulate([specs["C4"]], duration_s=1600).kept()
    w = Window("C4", r.op[0, -300:], r.pv[0, -300:], 1.0, float(r.t_s[-1]), "level")
    (report, details), = quantifier_fixture.quantify_with_details([w])
    assert report.oscillating
    file = tmp_path / "rec.rrd"
    sink = RerunSink(f"save:{file}", min_cloud_interval_s=0)
    still = report.model_copy(update={"oscillating": False})
    for k, rep in enumerate((report, still, still, report)):
        sink.log_report(rep, Window("C4", w.op, w.pv, 1.0, w.t_end_s + 10 * k, "level"), details)
    sink.close()
    rows: Counter[str] = Counter()
    cleared: Counter[str] = Counter()
    for chunk in rr.chunk.RrdReader(file).stream().to_chunks():
        if not chunk.is_static:
            rows[chunk.entity_path.lstrip("/")] += chunk.num_rows
            names = chunk.to_record_batch().schema.names
            cleared[chunk.entity_path.lstrip("/")] += any(n.startswith("Clear:") for n in names)
    assert rows[path("C4", "raw")] == 4
    assert rows[path("C4", "curve")] == 3 and cleared[path("C4", "curve")] == 1  # logged, cleared once, logged
    assert rows[path("C4", "clean")] == 3 and cleared[path("C4", "clean")] == 1
