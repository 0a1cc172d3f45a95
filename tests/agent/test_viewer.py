"""The rerun sink: a recording read back with rerun's own API has the entities and rows it should."""

from collections import Counter

import pytest

rr = pytest.importorskip("rerun")

from agent.pipeline import Window  # noqa: E402
from agent.viewer import ENTITIES, RerunSink, blueprint, path  # noqa: E402
from sim.grid import case_specs  # noqa: E402
from sim.loop import simulate  # noqa: E402


def test_recording_holds_every_loops_views_with_one_row_per_report(tmp_path, quantifier_fixture):
    specs = case_specs(seed=1)
    names = ["C4", "N4"]
    r = simulate([specs[n] for n in names], duration_s=1600).kept()
    file = tmp_path / "rec.rrd"
    sink = RerunSink(f"save:{file}")
    reports_per_loop, window, step = 3, 300, 100
    for k in range(reports_per_loop):
        end = window + k * step
        windows = [
            Window(n, r.op[i, end - window : end], r.pv[i, end - window : end], 1.0, float(r.t_s[end - 1]), "level")
            for i, n in enumerate(names)
        ]
        for w, (report, details) in zip(windows, quantifier_fixture.quantify_with_details(windows), strict=True):
            truth = (specs[w.loop_id].fs_pct, specs[w.loop_id].fd_pct) if w.loop_id == "C4" else None
            sink.log_report(report, w, details, truth)
    sink.close()

    rows: Counter[str] = Counter()
    for chunk in rr.chunk.RrdReader(file).stream().to_chunks():
        if not chunk.is_static:
            rows[chunk.entity_path.lstrip("/")] += chunk.num_rows
    for name in names:
        for what in ("raw", "curve", "clean", "fs_est", "fd_est", "flags"):
            assert rows[path(name, what)] == reports_per_loop, (name, what)
        # history goes in once: every sample of every window, no repeats
        assert rows[path(name, "op")] == rows[path(name, "pv")] == window + (reports_per_loop - 1) * step
    assert rows[path("C4", "fs_true")] == reports_per_loop and path("N4", "fs_true") not in rows
    assert set(ENTITIES) >= {"raw", "curve", "clean"}


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
    from agent.pipeline import Quantifier

    return Quantifier()
