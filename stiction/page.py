"""One self-contained HTML page for a plant's loops (``stiction report``): no server, no network.

The page is built from the same reports ``stiction quantify`` prints, in ``--rank``'s order: a
summary, the ranked table (sortable and filterable in the page), and per loop a section with its
record drawn (OP, PV, SP, the identified model's PV, the OP-PV plot), the warnings in words and
what to do next.  The figures are PNGs inlined as data URIs, so the file can be mailed.
"""

from __future__ import annotations

import base64
import io
import re
from collections import Counter
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from stiction.ranking import ORDER, SharedCycle, rank_key, shared_cycles
from stiction.schemas.errors import InputError
from stiction.schemas.report import StictionReport

PAGE_NAME = "stiction-report.html"
FIGURE_DPI = 62
"""Dots per inch of the inlined figures."""
FIGURE_COLOURS = 32
"""The figures' palette: line plots of a few colours lose nothing visible and shrink fourfold (PNG of
about 22 kB a loop instead of 83 kB: 3 MB for a hundred loops)."""
CREW_FIRST = 5
"""Sticky loops the summary names as the valve crew's first jobs."""


@dataclass(frozen=True)
class LoopEntry:
    """One loop on the page: where its report came from, the report, and its figure (PNG) if drawn."""

    source: str
    report: StictionReport
    figure_png: bytes | None = None


def figure_png(window, report: StictionReport, details) -> bytes:
    """The loop's record as ``quantify --plot`` draws it, without the title (the page says it in words)."""
    from PIL import Image  # matplotlib's own dependency

    from stiction.plots import plot_loop

    drawn, out = io.BytesIO(), io.BytesIO()
    plot_loop(drawn, window, report, details, title=False, dpi=FIGURE_DPI)
    image = Image.open(drawn).convert("RGB").quantize(colors=FIGURE_COLOURS, method=Image.Quantize.MEDIANCUT)
    image.save(out, format="PNG", optimize=True)
    return out.getvalue()


def _pm(x: float | None, se: float | None, nd: int = 2) -> str:
    if x is None:
        return "-"
    return f"{x:.{nd}f} ± {se:.{nd}f}" if se is not None else f"{x:.{nd}f}"


def next_steps(r: StictionReport) -> list[str]:
    """What an engineer does next about this loop, in words."""
    if r.verdict == "stiction":
        if r.s_pct is not None:
            band = (
                f"A valve travel test (small OP steps in manual, reversing direction) should show OP moving about "
                f"{_pm(r.s_pct, r.s_se_pct)} % of span after a reversal before the stem moves"
                + (f", and the stem jumping about {_pm(r.j_pct, r.j_se_pct)} % when it breaks away." if r.j_pct
                   is not None else ".")  # fmt: skip
            )
        else:
            band = (
                "The band was not read from this record (the warnings say why): a valve travel test measures it "
                "(small OP steps in manual, reversing direction; the OP travel before the stem moves is S)."
            )
        kind = {
            "stick_slip": " The stem sticks and then jumps (stick-slip): packing friction is the usual cause.",
            "deadband": " The stem does not jump: deadband or backlash (worn linkage, positioner) more than friction.",
        }.get(r.stiction_kind or "", "")
        return [
            "Plan valve maintenance: the valve's own nonlinearity drives this loop (packing, stem, seat or "
            "positioner)." + kind,
            band,
            "A stiction compensator (a knocker) or a slower controller (less gain, more integral time) only "
            "shrinks the cycle: a stopgap until the valve is repaired.",
        ]
    if r.verdict == "other_cause":
        period = f"{r.period_s:.0f} s" if r.period_s else "the same period"
        by_cause = {
            "external_oscillation": [
                f"Look upstream: another loop or unit cycling with a period near {period} disturbs this one.",
                "To confirm, put this loop in manual for a few periods: an external oscillation stays in PV, "
                "one the loop makes itself stops.",
            ],
            "tuning": [
                "Check the controller's tuning: too much gain or too little integral time makes a loop cycle.",
                "To confirm, a small setpoint step shows overshoot and slow decay; a valve travel test shows the "
                "valve healthy.",
            ],
            "quantization": [
                "PV or OP is stored in coarse steps (the historian's compression or the transmitter's "
                "resolution): the cycle may be an artefact of the record. Check the archive's deadband settings.",
            ],
        }
        cause = (r.likely_cause or "").replace("_", " ")
        return by_cause.get(
            r.likely_cause or "",
            [f"The loop oscillates, most like {cause or 'another cause'}, not like a sticky valve."],
        )
    if r.verdict == "no_oscillation":
        return ["Nothing to do now: the loop does not cycle. Keep it in the next report."]
    steps = [
        "Fix the record before judging the valve: "
        + (", ".join(c.replace("_", " ") for c in r.checks) or "the data checks failed")
        + " (the warnings say what is wrong). A dead or frozen PV is a sensor or archive fault; manual or a "
        "saturated OP means the controller cannot move the valve."
    ]
    if "compressed_op" in r.checks:
        steps.append(
            "The record is a historian's compressed archive (values stored only when they moved by the archive's "
            "deadband, straight lines between): export the raw values, or lower the tag's compression deviation "
            "below the signal's noise, and judge the valve on that."
        )
    return steps


def _anchor(loop_id: str, k: int) -> str:
    return f"loop-{k}-" + re.sub(r"[^A-Za-z0-9_-]", "_", loop_id)


def _process(r: StictionReport) -> str:
    p = r.process
    if p.description and p.source == "identified":
        from stiction.ident.trust import course_share

        return f"{p.description} ({course_share(p.pv_explained_share)})"
    if p.description:
        return p.description
    return "unknown" if p.kind == "unknown" else p.kind.replace("_", "-") + f" ({p.source})"


def _rows(entries: list[LoopEntry], cycles: list[SharedCycle] = ()) -> list[dict]:
    rows = []
    shared = {lid: g for g in cycles for lid in g.loop_ids}
    for k, e in enumerate(sorted(entries, key=lambda e: rank_key((e.source, e.report))), start=1):
        r = e.report
        steps = next_steps(r) + ([f"Shares its cycle: {shared[r.loop_id].text()}."] if r.loop_id in shared else [])
        rows.append(
            {
                "rank": k,
                "anchor": _anchor(r.loop_id, k),
                "source": e.source,
                "r": r,
                "verdict": r.verdict.replace("_", " "),
                "kind": (r.stiction_kind or "").replace("_", "-"),
                "cause": (r.likely_cause or "").replace("_", " ") if r.verdict == "other_cause" else "",
                "p": r.stiction_probability,
                "s": _pm(r.s_pct, r.s_se_pct),
                "j": _pm(r.j_pct, r.j_se_pct),
                "process": _process(r),
                "checks": ", ".join(r.checks),
                "steps": steps,
                "figure": base64.b64encode(e.figure_png).decode("ascii") if e.figure_png else None,
                "json": r.model_dump_json(indent=1),
            }
        )
    return rows


def render(entries: list[LoopEntry], source: str, generated: datetime | None = None) -> str:
    """The page's HTML for these loops (Jinja2, autoescaped)."""
    import jinja2

    from stiction import __version__

    env = jinja2.Environment(
        loader=jinja2.PackageLoader("stiction", "templates"),
        autoescape=jinja2.select_autoescape(("html", "j2")),
        undefined=jinja2.StrictUndefined,
    )
    cycles = shared_cycles([e.report for e in entries])
    rows = _rows(entries, cycles)
    counts = Counter(row["r"].verdict for row in rows)
    crew = [row for row in rows if row["r"].verdict == "stiction"][:CREW_FIRST]
    return env.get_template("report.html.j2").render(
        rows=rows,
        counts=[(v.replace("_", " "), counts.get(v, 0)) for v in ORDER],
        crew=crew,
        cycles=[g.text() for g in cycles],
        source=source,
        generated=(generated or datetime.now(UTC)).strftime("%Y-%m-%d %H:%M UTC"),
        version=__version__,
    )


def write(out_dir: Path, entries: list[LoopEntry], source: str) -> Path:
    """Write the page into ``out_dir`` (made if missing); returns its path."""
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        page = out_dir / PAGE_NAME
        page.write_text(render(entries, source), encoding="utf-8")
    except OSError as e:
        raise InputError(f"--out {out_dir}: cannot write the page ({e.strerror or e})") from None
    return page


def describe_source(paths: list[Path] | None = None, endpoint: str | None = None, prefix: str | None = None) -> str:
    """Where the page's reports came from, in words (escaped by the template)."""
    if endpoint:
        return f"the latest reports of the agents at {endpoint}, key space {prefix}"
    return "historian exports: " + ", ".join(str(p) for p in paths or [])
