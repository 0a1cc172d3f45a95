"""Plant triage (``stiction quantify DIR --rank``): loops ranked by what their valves cost the plant.

Sticky valves first, the widest band S first (a valve job is worth most where the band is
widest; the stiction probability breaks ties); then loops that oscillate for another reason,
by amplitude; then loops without oscillation; bad data last, so that it is seen and fixed.
"""

from __future__ import annotations

import csv
from pathlib import Path

from stiction.schemas.errors import InputError
from stiction.schemas.report import StictionReport

ORDER = {"stiction": 0, "other_cause": 1, "no_oscillation": 2, "bad_data": 3}
COLUMNS = ("rank", "loop", "verdict", "stiction_probability", "s_pct", "s_se_pct", "j_pct", "j_se_pct",
           "stiction_kind", "likely_cause", "amplitude_pct", "period_s", "warnings", "file")  # fmt: skip


def rank_key(item: tuple[str, StictionReport]):
    """Sort key of (source, report): sticky by band S, then oscillating by amplitude, then the rest."""
    r = item[1]
    size = r.s_pct if r.verdict == "stiction" else r.amplitude_pct
    return (ORDER[r.verdict], -(size or 0.0), -(r.stiction_probability or 0.0), r.loop_id)


def ranking(reports: list[tuple[str, StictionReport]]) -> list[dict]:
    rows = []
    for k, (path, r) in enumerate(sorted(reports, key=rank_key), start=1):
        rows.append({"rank": k, "loop": r.loop_id, "verdict": r.verdict,
                     "stiction_probability": r.stiction_probability, "s_pct": r.s_pct, "s_se_pct": r.s_se_pct,
                     "j_pct": r.j_pct, "j_se_pct": r.j_se_pct, "stiction_kind": r.stiction_kind,
                     "likely_cause": r.likely_cause,
                     "amplitude_pct": r.amplitude_pct, "period_s": r.period_s, "warnings": len(r.warnings),
                     "file": path})  # fmt: skip
    return rows


def print_ranking(reports: list[tuple[str, StictionReport]]) -> list[dict]:
    rows = ranking(reports)

    def f(x, nd=2):
        return "-" if x is None else f"{x:.{nd}f}"

    print(
        f"{'#':>3} {'loop':40s} {'verdict':15s} {'p':>5} {'S %':>12} {'J %':>12} {'ampl %':>7} {'period s':>9}  cause"
    )
    for row in rows:
        s = f"{f(row['s_pct'])}+-{f(row['s_se_pct'])}" if row["s_pct"] is not None else "-"
        j = f"{f(row['j_pct'])}+-{f(row['j_se_pct'])}" if row["j_pct"] is not None else "-"
        print(f"{row['rank']:3d} {row['loop'][:40]:40s} {row['verdict']:15s} {f(row['stiction_probability']):>5} "
              f"{s:>12} {j:>12} {f(row['amplitude_pct']):>7} {f(row['period_s'], 0):>9}  "
              f"{row['likely_cause'] or '-'}")  # fmt: skip
    counts = {v: sum(r["verdict"] == v for r in rows) for v in ORDER}
    print(f"{len(rows)} loops: " + ", ".join(f"{n} {v.replace('_', ' ')}" for v, n in counts.items()))
    return rows


def write_csv(path: Path, rows: list[dict]) -> None:
    try:
        with open(path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=COLUMNS)
            w.writeheader()
            w.writerows(rows)
    except OSError as e:
        raise InputError(f"--csv {path}: cannot write ({e.strerror})") from None
