"""``stiction bench measured``: diagnose every measured export of a folder, beside its labels where known.

The StictionGPT plant data carry the data authors' labels in ``loops.json`` (stiction or not,
loop type, tag); the DAMADICS loop carries none.  The table is what ``docs/measured-data.md``
is written from.
"""

from __future__ import annotations

import json
import multiprocessing
import os
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from stiction.schemas.errors import InputError


def _diagnose_file(path: str) -> tuple[dict | None, float, str | None]:
    """The diagnosis report of one export, the CPU seconds it took (reading the file included), and the one-line
    error where there is no report: one loop's failure is that loop's row, not the run's end."""
    from stiction.bridge.historian import read_export
    from stiction.ident.report import diagnose_loop

    started = time.process_time()
    try:
        export = read_export(path)
        # as ``stiction diagnose`` reads it: the setpoint too (the stuck-travel check reads OP's travel between
        # its moves)
        report, _, _ = diagnose_loop(
            Path(path).stem, export.op, export.pv, export.ts_s, export.mv, export.warnings, sp=export.sp
        )
    except InputError as e:
        return None, time.process_time() - started, str(e)
    except Exception as e:  # a defect, not the file's: said as one, and the other loops go on
        return None, time.process_time() - started, f"internal error: {type(e).__name__}: {e}"
    return json.loads(report.model_dump_json()), time.process_time() - started, None


def labels(folder: Path) -> dict[str, dict]:
    """Labels by file stem, from a ``loops.json`` beside or above the CSVs (the StictionGPT layout)."""
    for candidate in (folder / "loops.json", folder.parent / "loops.json"):
        if candidate.is_file():
            return {Path(r["csv"]).stem: r for r in json.loads(candidate.read_text())}
    return {}


def labelled_exports(paths: list[Path]) -> list[tuple[str, bool, object]]:
    """``(tag, labelled sticky, Export)`` for every export of ``paths`` (folders or files) that has a label."""
    from stiction.bridge.historian import expand_paths, read_export

    known: dict[str, dict] = {}
    for p in paths:
        known.update(labels(p if p.is_dir() else p.parent))
    out = []
    for p in paths:
        found = [(known[f.stem], f) for f in expand_paths([p]) if f.stem in known]
        if not found:  # else a folder one level too high was judged on nothing, and said nothing
            inside = [d.name for d in sorted(p.iterdir()) if d.is_dir()] if p.is_dir() else []
            hint = f" (its folders: {', '.join(inside)})" if inside else ""
            raise InputError(f"{p}: no labelled export here (CSV files named in a loops.json beside them){hint}")
        out += [(meta["tag"], meta["label"] == "stiction", read_export(f)) for meta, f in found]
    return out


def bench_measured(folders: list[Path], workers: int = 2) -> dict:
    listed = {f: sorted(f.glob("*.csv")) if f.is_dir() else [f] for f in folders}
    files = sorted(str(p) for found in listed.values() for p in found)
    empty = [str(f) for f, found in listed.items() if not found]
    if empty:
        raise InputError(f"{', '.join(empty)}: no CSV export here (the exports may be in a folder inside)")
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        done = list(pool.map(_diagnose_file, files))
    failed = [{"file": Path(path).name, "error": err} for path, (_, _, err) in zip(files, done, strict=True) if err]
    kept = [(path, r, s) for path, (r, s, err) in zip(files, done, strict=True) if err is None]
    files, reports, seconds = [k[0] for k in kept], [k[1] for k in kept], [k[2] for k in kept]
    known = {}
    for f in folders:
        known.update(labels(f if f.is_dir() else f.parent))
    rows = []
    for path, r, cpu_s in zip(files, reports, seconds, strict=True):
        meta = known.get(Path(path).stem, {})
        rows.append({"file": path, "label": meta.get("label"), "tag": meta.get("tag"), "type": meta.get("loop_type"),
                     "report": r, "cpu_s": cpu_s})  # fmt: skip
    labelled = [row for row in rows if row["label"]]
    called = [(row["report"]["stiction_delta_criterion"] > 0, row["label"] == "stiction") for row in labelled]
    summary = {
        "loops": len(rows),
        "failed": failed,
        "labelled": len(labelled),
        "stiction_earns_its_place": {
            "true_positive": sum(c and t for c, t in called),
            "false_positive": sum(c and not t for c, t in called),
            "true_negative": sum(not c and not t for c, t in called),
            "false_negative": sum(not c and t for c, t in called),
        },
        "causes": {},
        "cpu_s_median": float(np.median(seconds)) if seconds else None,
        "cpu_s_max": float(np.max(seconds)) if seconds else None,
        "slowest": Path(files[int(np.argmax(seconds))]).name if seconds else None,
    }
    for row in rows:
        for c in row["report"]["causes"]:
            summary["causes"][c] = summary["causes"].get(c, 0) + 1
    return {"rows": rows, "summary": summary}


def markdown(figures: dict) -> str:
    """One table row per loop: label, what diagnose found, the gain, S and J."""

    def f(x, nd=2):
        return "–" if x is None else f"{x:.{nd}f}"

    from stiction.sim.extensions import CATALOGUE

    head = "| loop | label | process identified | causes (parameters) | fit error canonical → extended "
    lines = [head + "| S ± se | J ± se | stiction ΔBIC |", "|---|---|---|---|---|---|---|---|"]
    for row in figures["rows"]:
        r = row["report"]

        def params(cause, r=r):
            return ", ".join(f"{k} {r['parameters'][k]:.3g}" for k in CATALOGUE.get(cause, ()) if k in r["parameters"])

        causes = "; ".join(f"{c} ({params(c)})" for c in r["causes"]) or "none"
        s = f"{f(r['s_pct'])} ± {f(r['s_se_pct'])}" if r["s_pct"] is not None else "withheld"
        j = f"{f(r['j_pct'])} ± {f(r['j_se_pct'])}" if r["j_pct"] is not None else "withheld"
        name = r["loop_id"].replace("stic_", "").split("_Stick1")[0]
        lines.append(
            f"| {name} | {row['label'] or '–'} | {r['process']['description']} | {causes} | "
            f"{r['base_error']:.3g} → {r['extended_error']:.3g} % ({r['gain_pct']:.0f} %) | {s} | {j} | "
            f"{r['stiction_delta_criterion']:.0f} |"
        )
    return "\n".join(lines)


def print_summary(figures: dict) -> None:
    """The run's summary as text: stiction's place by BIC against the labels, the causes named."""
    s = figures["summary"]
    c = s["stiction_earns_its_place"]
    print(f"{s['loops']} loops, {s['labelled']} labelled; stiction earns its place (BIC): "
          f"{c['true_positive']} of {c['true_positive'] + c['false_negative']} labelled sticky, "
          f"{c['false_positive']} of {c['false_positive'] + c['true_negative']} labelled not")  # fmt: skip
    print("causes named: " + ", ".join(f"{k} {v}" for k, v in sorted(s["causes"].items(), key=lambda kv: -kv[1])))
    for fail in s.get("failed", []):
        print(f"not diagnosed: {fail['file']}: {fail['error']}")
    if s.get("cpu_s_max") is not None:
        print(f"CPU seconds a loop (reading and diagnosing, one core each): median {s['cpu_s_median']:.1f}, "
              f"largest {s['cpu_s_max']:.1f} ({s['slowest']})")
