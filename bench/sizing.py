"""``stiction bench sizing``: S and J on simulated plant-like sticky loops, as ``stiction quantify`` reports them.

Loops: the sticky class of ``sim.plant_loops`` (processes, tunings, dead times and historian
sampling of their own; OP, PV and SP only), one seed; or (``--simulator two_parameter``) the
independent simulator's sticky loops, whose valve the fit does not assume.  Each goes through the quantify
pipeline with the process identification on (``ident.sizing``); for the loops it calls
sticky the bench prints how many got S and J, their median relative error, and how often
the truth lies inside S +- 2 s_se_pct and J +- 2 j_se_pct (the issue's goal: S within 25 %,
both inside for >= 80 %).  Beside it, for the same loops: the fit's own standard errors
without the model error, and the learned thesis-loop models' reading (shown in the
report's ``learned`` block, never its headline for such loops).  ``--direct-acting`` records every loop as a
direct-acting controller would: PV falling as the valve opens (a level held by its outlet, a pressure by its vent),
OP mirrored (100 - OP) and nothing else changed, the same valves read from the other side.
"""

from __future__ import annotations

import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor

import numpy as np

_QUANTIFIER = None


def _one(item) -> dict:
    from stiction.ident.trust import MODEL_ERROR_J, MODEL_ERROR_S
    from stiction.quantify.identified import quantify_sized
    from stiction.quantify.pipeline import Quantifier, Window
    from stiction.sim.valve import band_and_jump_pct, band_and_jump_se_pct

    global _QUANTIFIER
    if _QUANTIFIER is None:
        _QUANTIFIER = Quantifier()
    s_true, j_true, every, (op, pv, sp, ts_s) = item
    started = time.process_time()
    r = quantify_sized(_QUANTIFIER, [Window("loop", op, pv, ts_s=ts_s, sp=sp)])[0][0]
    why = next((w for w in r.warnings if w.startswith("S and J not read")), None)
    row = {"s_true": s_true, "j_true": j_true, "every": every, "verdict": r.verdict, "method": r.method,
           "cpu_s": time.process_time() - started, "s": r.s_pct, "j": r.j_pct, "s_se": r.s_se_pct,
           "j_se": r.j_se_pct, "why": why}  # fmt: skip
    if r.s_pct is not None:
        # the fit's own errors: the model error taken back out
        row["s_se_fit"] = float(np.sqrt(max(r.s_se_pct**2 - (MODEL_ERROR_S * r.s_pct) ** 2, 0.0)))
    if r.j_pct is not None:  # a report may give S without J (the schema allows it)
        row["j_se_fit"] = float(np.sqrt(max(r.j_se_pct**2 - (MODEL_ERROR_J * r.s_pct) ** 2, 0.0)))
    if r.learned.fs_pct is not None:
        s, j = band_and_jump_pct(r.learned.fs_pct, r.learned.fd_pct)
        s_se, _ = band_and_jump_se_pct(r.learned.fs_se_pct, r.learned.fd_se_pct or 0.0)
        row["learned_s"], row["learned_s_se"] = float(s), float(s_se)
        row["learned_j"] = float(j)
    return row


def _score(rows: list[dict], s: str, s_se: str | None, j: str | None = None, j_se: str | None = None) -> dict:
    read = [r for r in rows if r.get(s) is not None]
    out = {"read": len(read)}
    if not read:
        return out
    out["s_median_rel_err"] = float(np.median([abs(r[s] - r["s_true"]) / r["s_true"] for r in read]))
    if s_se:
        out["s_covered"] = float(np.mean([abs(r[s] - r["s_true"]) <= 2 * r[s_se] for r in read]))
    if j and j_se:
        with_j = [r for r in read if r.get(j) is not None]  # a report may give S without J (the schema allows it)
        out["j_read"] = len(with_j)
        if with_j:
            out["j_covered"] = float(np.mean([abs(r[j] - r["j_true"]) <= 2 * r[j_se] for r in with_j]))
    return out


SIMULATORS = ("plant", "two_parameter", "families")
"""Where the sticky loops come from: ``sim.plant_loops`` (the physical valve the fit assumes, under processes and
tunings of its own), or ``sim.two_parameter``, the independent simulator (Choudhury's data-driven valve, which the
fit does not assume, under SIMC-tuned flows and levels): its loops whose record shows a fault, stick-slip or
backlash, S and J by the same definition; or ``sim.plant_families``, the families the verdict is judged on (flow,
level, slow and detuned loops; stick-slip, He's valve, backlash and both; setpoint steps, loads, coloured noise,
sampling up to 60 s): their loops whose record of ``FAMILY_SAMPLES`` shows the fault."""
FAMILY_SAMPLES = 1000
"""The families' records as the agent's window holds them (the families' own windows are 600 samples)."""


def _items(simulator: str, n: int, seed: int) -> list:
    """(S, J, the record's sample interval in samples, (op, pv, sp, ts_s)) of each sticky loop."""
    if simulator == "plant":
        from stiction.sim.plant_loops import plant_loops, simulate_plant, stable

        loops = [loop for loop in plant_loops(n, seed) if loop.cause == "stiction"]
        return [
            (loop.s_pct, loop.j_pct, loop.every, rec)
            for loop, rec in zip(loops, simulate_plant(loops), strict=True)
            if stable(rec[0], rec[1])
        ]
    if simulator == "two_parameter":
        from stiction.sim import two_parameter
        from stiction.sim.plant_families import stable

        loops = [loop for loop in two_parameter.draw(n, seed) if loop.cause in ("stiction", "backlash")]
        return [
            (loop.s_pct, loop.j_pct, 1, (rec.op, rec.pv, rec.sp, rec.ts_s))
            for loop, rec in zip(loops, two_parameter.simulate(loops), strict=True)
            if stable(rec) and rec.shows_fault
        ]
    if simulator == "families":
        from stiction.sim.plant_families import FAULTS, family_loops, simulate_families, stable

        loops = [loop for loop in family_loops(n, seed) if loop.cause in FAULTS]
        return [
            (loop.s_pct, loop.j_pct, loop.every, (rec.op, rec.pv, rec.sp, rec.ts_s))
            for loop, rec in zip(loops, simulate_families(loops, samples=FAMILY_SAMPLES), strict=True)
            if stable(rec) and rec.shows_fault
        ]
    raise ValueError(f"simulator {simulator!r}: one of {', '.join(SIMULATORS)}")


def _mirrored(item):
    """The loop as a direct-acting controller records it: the same valve and PV, OP as 100 - OP (S and J are OP
    travels and do not change)."""
    s_true, j_true, every, (op, pv, sp, ts_s) = item
    return s_true, j_true, every, (100.0 - np.asarray(op, float), pv, sp, ts_s)


def bench_sizing(
    n_per_class: int = 60, seed: int = 2030, workers: int = 2, simulator: str = "plant", direct_acting: bool = False
) -> dict:
    t0 = time.perf_counter()
    items = _items(simulator, n_per_class, seed)
    if direct_acting:
        items = [_mirrored(item) for item in items]
    if workers > 1:
        with ProcessPoolExecutor(workers) as pool:
            rows = list(pool.map(_one, items))
    else:
        rows = [_one(item) for item in items]
    called = [r for r in rows if r["verdict"] == "stiction"]
    why = Counter(_reason(r["why"]) for r in called if r["s"] is None)
    return {
        "seed": seed,
        "simulator": simulator,
        "direct_acting": direct_acting,
        "loops": len(rows),
        "called_sticky": len(called),
        "identified": _score(called, "s", "s_se", "j", "j_se"),
        "fit_errors_only": _score(called, "s", "s_se_fit", "j", "j_se_fit"),
        "learned": _score(called, "learned_s", "learned_s_se"),
        "not_read": dict(why),
        "cpu_s_per_sticky_loop": float(np.median([r["cpu_s"] for r in called])) if called else None,
        "seconds": time.perf_counter() - t0,
        "rows": rows,
    }


def _reason(why: str | None) -> str:
    if why is None:
        return "other"
    for key, name in (("dragged", "a dragged valve: no stuck phase"), ("stop at its bound", "S, J not separable"),
                      ("slip", "too few slips"),
                      ("jump", "S, J not separable"), ("does not stick", "linear valve explains PV as well"),
                      ("identified", "identification failed")):  # fmt: skip
        if key in why:
            return name
    return why[:60]


def print_table(fig: dict) -> None:
    what = {
        "plant": "simulated plant-like sticky loops",
        "two_parameter": "the independent simulator's sticky loops (sim.two_parameter, Choudhury's valve)",
        "families": f"the verdict's families' sticky loops (sim.plant_families, records of {FAMILY_SAMPLES} samples)",
    }
    recorded = ", recorded direct-acting (OP as 100 - OP)" if fig.get("direct_acting") else ""
    print(f"{what[fig.get('simulator', 'plant')]} (seed {fig['seed']}{recorded}): {fig['called_sticky']} of "
          f"{fig['loops']} called sticky; S and J on those, as stiction quantify reports them")  # fmt: skip
    print(f"{'':44s}{'S read':>7s}{'J read':>7s}{'S med. rel err':>16s}{'S in 2se':>10s}{'J in 2se':>10s}")
    labels = {"identified": "identified process (the report's headline)",
              "fit_errors_only": "  same, the fit's own errors only",
              "learned": "learned thesis-loop models (block only)"}  # fmt: skip
    for key, label in labels.items():
        s = fig[key]
        cells = [f"{s['read']:7d}", f"{s['j_read']:7d}" if "j_read" in s else f"{'-':>7s}"]
        cells.append(f"{100 * s['s_median_rel_err']:15.0f}%" if "s_median_rel_err" in s else f"{'-':>16s}")
        for k in ("s_covered", "j_covered"):
            cells.append(f"{100 * s[k]:9.0f}%" if k in s else f"{'-':>10s}")
        print(f"{label:44s}" + "".join(cells))
    if fig["not_read"]:
        print("not read (the report says why): " + ", ".join(f"{k} {v}" for k, v in fig["not_read"].items()))
    cpu = fig["cpu_s_per_sticky_loop"]
    print(f"CPU per sticky loop (median): {cpu:.1f} s; {fig['seconds']:.0f} s wall" if cpu else "")
