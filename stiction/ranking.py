"""Plant triage (``stiction quantify DIR --rank``): loops ranked by what their valves cost the plant.

Sticky valves first, the widest band S first (a valve job is worth most where the band is
widest; the stiction probability breaks ties); then loops that oscillate for another reason,
by amplitude; then loops without oscillation; bad data last, so that it is seen and fixed.  Loops that cycle
with one period over the same hours are named together (``shared_cycles``): one cause may drive them all, and the
loop whose own valve reads stickiest is the one to fix first.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

from stiction.schemas.errors import InputError
from stiction.schemas.report import StictionReport

ORDER = {"stiction": 0, "other_cause": 1, "no_oscillation": 2, "bad_data": 3}
COLUMNS = ("rank", "loop", "verdict", "stiction_probability", "s_pct", "s_se_pct", "j_pct", "j_se_pct",
           "stiction_kind", "likely_cause", "amplitude_pct", "period_s", "shared_cycle", "warnings",
           "file")  # fmt: skip
PERIOD_SHARE = 0.05
"""Loops' cycles are one where every period of the group is within this share of its shortest (a limit cycle's period
reads to a percent or two; a tolerance that chained neighbour to neighbour would join a plant's unrelated loops)."""
OVERLAP_SHARE = 0.5
"""... and where every two records share at least this share of the shorter one's span, in calendar time."""
CALENDAR_FROM_S = 1e8
"""A window's end from this many seconds on is a calendar time (seconds since 1970), as exports and the OPC UA bridge
stamp them.  Records stamped from zero (a simulation's, some exports') cannot say they are of the same hours, and are
grouped with none."""


@dataclass(frozen=True)
class SharedCycle:
    """Loops whose oscillations have one period over the same hours: one cause may drive them all (an upstream
    loop's sticky valve sends its cycle down the line as a square or triangular load, which a downstream loop reads
    much as it would its own valve's).  ``source``: the member whose own valve reads stickiest (verdict stiction,
    highest probability), the one to fix first, or None where none is called sticky."""

    loop_ids: tuple[str, ...]
    period_s: float
    source: str | None

    def text(self) -> str:
        others = [lid for lid in self.loop_ids if lid != self.source]
        head = (f"{', '.join(self.loop_ids)} cycle at about {self.period_s:.0f} s over the same hours: one cause may "
                "drive them all")  # fmt: skip
        if self.source is None:
            return head + "; none reads as a sticky valve of its own: look upstream, or at a common load"
        return (f"{head}; {self.source}'s valve reads stickiest: fix it first, then look again at "
                f"{', '.join(others)}, whose cycle may be its")  # fmt: skip


def _span(r: StictionReport) -> tuple[float, float] | None:
    """The record's span in calendar time, or None where it is not stamped so."""
    if r.t_end_s is None or r.t_end_s < CALENDAR_FROM_S or not r.process.sample_time_s:
        return None
    return r.t_end_s - r.n_samples * r.process.sample_time_s, r.t_end_s


def _same_hours(a: tuple[float, float], b: tuple[float, float]) -> bool:
    shared = min(a[1], b[1]) - max(a[0], b[0])
    return shared >= OVERLAP_SHARE * min(a[1] - a[0], b[1] - b[0])


def shared_cycles(reports: list[StictionReport]) -> list[SharedCycle]:
    """The groups of two or more oscillating loops (``stiction`` or ``other_cause``, a period read, a record in
    calendar time) that share one cycle: every period within ``PERIOD_SHARE`` of the group's shortest and every two
    records of the same hours (``OVERLAP_SHARE``).  Loops taken shortest period first, each joining the first group it
    fits; each loop in one group at most."""
    cycling = sorted(
        ((r, span) for r in reports if r.verdict in ("stiction", "other_cause") and r.period_s and r.period_s > 0
         for span in [_span(r)] if span is not None),
        key=lambda item: item[0].period_s,
    )  # fmt: skip
    groups: list[list[tuple]] = []
    for r, span in cycling:
        for g in groups:
            if r.period_s <= (1 + PERIOD_SHARE) * g[0][0].period_s and all(_same_hours(span, s) for _, s in g):
                g.append((r, span))
                break
        else:
            groups.append([(r, span)])
    out = []
    for g in groups:
        members = [r for r, _ in g]
        if len(members) < 2:
            continue
        sticky = [r for r in members if r.verdict == "stiction"]
        source = max(sticky, key=lambda r: (r.stiction_probability or 0.0, r.s_pct or 0.0)).loop_id if sticky else None
        period = float(sorted(r.period_s for r in members)[len(members) // 2])
        out.append(SharedCycle(tuple(sorted(r.loop_id for r in members)), period, source))
    return sorted(out, key=lambda g: g.loop_ids)


def cycle_of(groups: list[SharedCycle]) -> dict[str, int]:
    """Each grouped loop's group, numbered from 1."""
    return {lid: k for k, g in enumerate(groups, start=1) for lid in g.loop_ids}


def rank_key(item: tuple[str, StictionReport]):
    """Sort key of (source, report): sticky by band S, then oscillating by amplitude, then the rest."""
    r = item[1]
    size = r.s_pct if r.verdict == "stiction" else r.amplitude_pct
    return (ORDER[r.verdict], -(size or 0.0), -(r.stiction_probability or 0.0), r.loop_id)


def ranking(reports: list[tuple[str, StictionReport]], cycles: list[SharedCycle] | None = None) -> list[dict]:
    """The table's rows in rank order; ``cycles``: the reports' ``shared_cycles``, where the caller has them."""
    rows = []
    group = cycle_of(shared_cycles([r for _, r in reports]) if cycles is None else cycles)
    for k, (path, r) in enumerate(sorted(reports, key=rank_key), start=1):
        rows.append({"rank": k, "loop": r.loop_id, "verdict": r.verdict,
                     "stiction_probability": r.stiction_probability, "s_pct": r.s_pct, "s_se_pct": r.s_se_pct,
                     "j_pct": r.j_pct, "j_se_pct": r.j_se_pct, "stiction_kind": r.stiction_kind,
                     "likely_cause": r.likely_cause,
                     "amplitude_pct": r.amplitude_pct, "period_s": r.period_s,
                     "shared_cycle": group.get(r.loop_id), "warnings": len(r.warnings), "file": path})  # fmt: skip
    return rows


def print_ranking(reports: list[tuple[str, StictionReport]]) -> list[dict]:
    cycles = shared_cycles([r for _, r in reports])
    rows = ranking(reports, cycles)

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
    for k, g in enumerate(cycles, start=1):
        print(f"shared cycle {k}: {g.text()}")
    return rows


def write_csv(path: Path, rows: list[dict]) -> None:
    try:
        with open(path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=COLUMNS)
            w.writeheader()
            w.writerows(rows)
    except OSError as e:
        raise InputError(f"--csv {path}: cannot write ({e.strerror})") from None
