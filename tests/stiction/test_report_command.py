"""``stiction report``: the plant page as an engineer opens it, from exports and from a live key space."""

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from stiction import page
from stiction.cli import main
from stiction.schemas.report import ProcessInfo, StictionReport

ROOT = Path(__file__).resolve().parents[2]
PLAYWRIGHT = ROOT / "build" / "browser" / "node_modules" / "playwright-core"
CHECK_JS = Path(__file__).with_name("report_page_check.js")


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    d = tmp_path_factory.mktemp("exports")
    main(["simulate", "--fs-pct", "50", "--fd-pct", "20", "--out", str(d / "sticky_a.csv")])
    main(["simulate", "--case", "N1", "--seed", "2", "--out", str(d / "sticky_n1.csv")])
    rng = np.random.default_rng(0)
    rows = "\n".join(f"{k},{50 + rng.normal(0, 2):.3f},42.0" for k in range(600))  # PV dead: bad data
    (d / "dead_pv.csv").write_text("t,op,pv\n" + rows + "\n")
    (d / "broken.csv").write_text("t,op,pv\n0,1,2\n1,x,2\n")
    return d


@pytest.fixture(scope="module")
def written(exports, tmp_path_factory):
    out = tmp_path_factory.mktemp("page")
    done = subprocess.run(
        [sys.executable, "-m", "stiction.cli", "report", str(exports), "--out", str(out), "--jobs", "1"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    return done, out / page.PAGE_NAME


def _table_loops(html: str) -> list[str]:
    body = html.split('<table id="loops">', 1)[1].split("</table>", 1)[0]
    return re.findall(r'<a href="#loop-[^"]+" class="open">([^<]+)</a>', body)


def test_a_folder_of_exports_makes_one_ranked_page_and_a_bad_file_is_named(written):
    done, html_path = written
    assert done.returncode == 2, done.stderr  # the broken file: exit 2, the others on the page
    assert "broken.csv: row 3, column 'op': 'x' is not a number" in done.stderr and "Traceback" not in done.stderr
    assert f"{html_path}: 3 loops" in done.stdout
    html = html_path.read_text()
    loops = _table_loops(html)
    assert loops[-1] == "dead_pv" and set(loops[:2]) == {"sticky_a", "sticky_n1"}  # sticky first, bad data last
    assert html.count('<details class="loop"') == 3
    assert html.count("data:image/png;base64,") == 3  # every record drawn, inline
    assert "Plan valve maintenance" in html and "Fix the record before judging the valve" in html
    assert "<script src" not in html and 'href="http' not in html  # nothing fetched: it opens from a mail
    assert html_path.stat().st_size < 3 * 200_000  # a few MB for a hundred loops


def _report(loop_id: str, verdict: str, **kw) -> StictionReport:
    base = dict(
        loop_id=loop_id, verdict=verdict, stiction_probability=0.9 if verdict == "stiction" else 0.1,
        likely_cause="stiction" if verdict == "stiction" else None, regularity=3.0, amplitude_pct=1.0, checks=[],
        process=ProcessInfo(kind="unknown", source="none", sample_time_s=1.0), fs_pct=None, fd_pct=None,
        s_pct=None, j_pct=None, s_se_pct=None, j_se_pct=None, fs_se_pct=None, fd_se_pct=None, period_s=100.0,
        denoised=False, method="none", thesis={"fs_pct": None, "fd_pct": None}, physical=None,
        learned={"fs_pct": None, "fd_pct": None}, ood_score=None, explained=None, oscillating=True,
        model_version="test", n_samples=1000,
    )  # fmt: skip
    return StictionReport(**(base | kw))


def test_what_to_do_next_follows_the_verdict_and_names_the_band_to_expect():
    sticky = page.next_steps(_report("v", "stiction", s_pct=2.5, s_se_pct=0.3, j_pct=1.0, j_se_pct=0.2))
    assert any("2.50 ± 0.30 % of span after a reversal" in s for s in sticky)
    assert any("stopgap" in s for s in sticky)
    unread = page.next_steps(_report("v", "stiction"))
    assert any("not read from this record" in s for s in unread)
    external = page.next_steps(_report("v", "other_cause", likely_cause="external_oscillation", period_s=340.0))
    assert any("340 s" in s for s in external) and any("manual" in s for s in external)
    bad = page.next_steps(_report("v", "bad_data", checks=["flat_pv"], stiction_probability=None))
    assert "flat pv" in bad[0] and not any("compression deviation" in s for s in bad)
    archive = page.next_steps(_report("v", "bad_data", checks=["compressed_op"], stiction_probability=None))
    assert any("export the raw values" in s and "compression deviation" in s for s in archive)


def test_names_from_the_plant_are_text_not_markup():
    html = page.render([page.LoopEntry("x.csv", _report("<script>alert(1)</script>", "no_oscillation"))], "test")
    assert "<script>alert(1)</script>" not in html and "&lt;script&gt;alert(1)&lt;/script&gt;" in html


def test_the_latest_reports_of_a_live_key_space_make_the_same_page(tmp_path):
    """An agent's key space, answered by a queryable as the agent does; ``report --from`` collects it."""
    import zenoh

    from stiction.bridge import zenoh_session
    from stiction.schemas import keys

    endpoint = zenoh_session.free_loopback_endpoint()
    prefix = "test/report"
    latest = {
        "FIC1": _report("FIC1", "stiction", s_pct=3.0, s_se_pct=0.4, j_pct=1.0, j_se_pct=0.3, t_end_s=100.0),
        "LIC2": _report("LIC2", "other_cause", likely_cause="tuning", t_end_s=100.0),
    }

    def answer(query):
        json_encoding = zenoh.Encoding.APPLICATION_JSON
        for loop_id, r in latest.items():
            query.reply(keys.report(prefix, loop_id), r.model_dump_json().encode(), encoding=json_encoding)
        query.reply(keys.report(prefix, "junk"), b"{not json", encoding=json_encoding)

    session = zenoh.open(zenoh_session.build(listen=[endpoint]))
    try:
        queryable = session.declare_queryable(keys.all_reports(prefix), answer)
        out = tmp_path / "live"
        done = subprocess.run(
            [sys.executable, "-m", "stiction.cli", "report", "--from", endpoint, "--prefix", prefix, "--out", str(out),
             "--timeout", "3"],
            capture_output=True, text=True, timeout=120,
        )  # fmt: skip
        queryable.undeclare()
    finally:
        session.close()
    assert done.returncode == 0, done.stderr
    assert "1 replies were not valid reports" in done.stderr
    html = (out / page.PAGE_NAME).read_text()
    assert _table_loops(html) == ["FIC1", "LIC2"]
    assert "3.00 ± 0.40" in html and "a live report carries no samples" in html


def test_nothing_to_report_on_is_one_line(tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "stiction.cli", "report", "--out", str(tmp_path)], capture_output=True, text=True
    )
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "nothing to report on" in done.stderr
    endpoint = "tcp/127.0.0.1:9"  # nothing listens there
    done = subprocess.run(
        [sys.executable, "-m", "stiction.cli", "report", "--from", endpoint, "--out", str(tmp_path), "--timeout", "1"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2 and "Traceback" not in done.stderr and done.stderr.strip().count("\n") == 0


@pytest.mark.skipif(shutil.which("chromium") is None, reason="no Debian chromium (bash scripts/test installs it)")
@pytest.mark.skipif(
    not PLAYWRIGHT.is_dir(), reason="no playwright-core in build/browser (bash scripts/test installs it)"
)
def test_the_page_in_a_real_browser_loads_sorts_filters_and_opens_a_loop(written):
    _, html_path = written
    shots = ROOT / "build" / "report-page"
    shots.parent.mkdir(exist_ok=True)
    done = subprocess.run(
        ["node", str(CHECK_JS), str(html_path), str(shots)],
        capture_output=True,
        text=True,
        timeout=120,
        env=os.environ | {"PW_CORE": str(PLAYWRIGHT)},
    )
    assert done.returncode == 0, done.stderr[-2000:]
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    assert seen["errors"] == [] and seen["requests"] == []
    assert seen["rows"] == 3
    s_up = [float(v) for v in seen["s_ascending"] if v]
    s_down = [float(v) for v in seen["s_descending"] if v]
    assert s_up == sorted(s_up) and s_down == sorted(s_down, reverse=True) and len(s_up) >= 1
    assert seen["s_ascending"][-1] == "" and seen["s_descending"][-1] == ""  # loops without S last, either way
    assert seen["ranks_after"] == ["1", "2", "3"]
    assert seen["opened"] and seen["opened_has_figure"]
    assert seen["visible_after_filter"] and set(seen["visible_after_filter"]) == {"stiction"}
    assert (shots.parent / "report-page-loop.png").stat().st_size > 10_000
