"""``stiction bench detect``: is it the valve?  The detector beside the published tests, side by side.

Two sets, same run:

- simulated plant-like loops of every class (``sim.plant_loops``, a seed the shipped detector
  was not trained on): the share of each class called stiction by each method;
- the labelled measured windows (``loops.json`` beside the CSVs): accuracy against the data
  authors' labels, the detector cross-validated by tag (each tag's windows judged by a
  detector trained without any window of that tag).

Methods: Horch's cross-correlation test (stiction where it reads an odd CCF), Choudhury's
bicoherence test (nonlinear and oscillating), He et al.'s shape test (SI of OP > 0.6), and
the project's verdict (data checks, then the detector's stiction probability >= ``STICTION_AT``), with
its stuck-valve tests (OP ramps while PV stands still; a setpoint step PV followed only
after OP had ramped, ``detect.verdict.StuckRule``) alone beside it.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from detect.training import SIM_SEED

METHODS = ("ours", "stuck", "horch", "bicoherence", "shape")


def _calls(ev, p_stiction: float, blocked: bool) -> dict[str, bool]:
    from detect.shape import STICTION as SHAPE_STICTION
    from detect.verdict import STEP_AT, STICTION_AT, STUCK_AT

    ramp, step = ev.stuck
    return {
        "ours": bool(not blocked and p_stiction >= STICTION_AT),
        "stuck": bool(not blocked and (ramp >= STUCK_AT or step >= STEP_AT)),
        "horch": ev.horch.verdict == "stiction",
        "bicoherence": bool(ev.bicoherence.nonlinear and ev.oscillation.oscillating),
        "shape": bool(np.isfinite(ev.shape_op) and ev.shape_op > SHAPE_STICTION),
    }


def _blocked(op, pv) -> bool:
    from ident.checks import blocking, data_checks

    return bool(blocking(data_checks(op, pv)))


def bench_detect(measured: list[Path], n_per_class: int = 40, seed: int = 2026, train_per_class: int = 60) -> dict:
    from bench.measured import labelled_exports
    from detect import training
    from detect.features import evidence
    from detect.verdict import STICTION_AT
    from sim.plant_loops import CLASSES, plant_loops, simulate_plant, stable

    t0 = time.perf_counter()
    x_train, causes_train, stuck_train = training.simulated_set(train_per_class, SIM_SEED)
    detector = training.train(x_train, causes_train, stuck=stuck_train)
    out: dict = {"simulated": {}, "measured": {}}

    loops = plant_loops(n_per_class, seed)
    t1 = time.perf_counter()
    records = simulate_plant(loops)
    kept = [i for i, r in enumerate(records) if stable(r[0], r[1])]
    out["diverged"] = len(loops) - len(kept)
    loops, records = [loops[i] for i in kept], [records[i] for i in kept]
    evs = [evidence(op, pv, ts_s, sp) for op, pv, sp, ts_s in records]
    feature_s = (time.perf_counter() - t1) / len(loops)
    x_sim = np.nan_to_num(np.array([e.vector for e in evs]))
    stuck_sim = np.array([e.stuck for e in evs])
    p = detector.stiction_probability(x_sim, stuck_sim)
    blocked = [_blocked(op, pv) for op, pv, _, _ in records]
    by_class = {cls: [i for i, loop in enumerate(loops) if loop.cause == cls] for cls in CLASSES}
    for cls, idx in by_class.items():
        called = [_calls(evs[i], p[i], blocked[i]) for i in idx]
        out["simulated"][cls] = {m: float(np.mean([c[m] for c in called])) for m in METHODS} | {"n": len(idx)}
    out["simulated_seconds_per_loop"] = feature_s

    rows = [
        (tag, sticky, evidence(e.op, e.pv, e.ts_s, e.sp), _blocked(e.op, e.pv))
        for tag, sticky, e in labelled_exports(measured)
    ]
    if rows:
        tags = [r[0] for r in rows]
        xm = np.nan_to_num(np.array([r[2].vector for r in rows]))
        stuck_m = np.array([r[2].stuck for r in rows])
        sticky = [r[1] for r in rows]
        p_cv = np.zeros(len(rows))
        for tag in sorted(set(tags)):
            keep = [i for i, t in enumerate(tags) if t != tag]
            held = [i for i, t in enumerate(tags) if t == tag]
            d = training.train(x_train, causes_train, xm[keep], [sticky[i] for i in keep], [tags[i] for i in keep],
                               stuck=stuck_train)  # fmt: skip
            p_cv[held] = d.stiction_probability(xm[held], stuck_m[held])
        calls = [_calls(r[2], p_cv[i], r[3]) for i, r in enumerate(rows)]
        p_sim = detector.stiction_probability(xm, stuck_m)
        calls_sim = [_calls(r[2], p_sim[i], r[3])["ours"] for i, r in enumerate(rows)]
        truth = np.array(sticky)
        out["measured"] = {
            "windows": len(rows),
            "tags": len(set(tags)),
            "sticky": int(truth.sum()),
            "bad_data": int(sum(r[3] for r in rows)),
            "accuracy": {m: float(np.mean(np.array([c[m] for c in calls]) == truth)) for m in METHODS},
            "recall": {m: float(np.mean(np.array([c[m] for c in calls])[truth])) for m in METHODS},
            "specificity": {m: float(np.mean(~np.array([c[m] for c in calls])[~truth])) for m in METHODS},
            "accuracy_simulation_only": float(np.mean(np.array(calls_sim) == truth)),
        }
        out["measured"]["near_threshold"] = int(np.sum(np.abs(p_cv - STICTION_AT) < 0.1))
        shipped = training.train(x_train, causes_train, xm, sticky, tags, stuck=stuck_train)
        p_shipped = shipped.stiction_probability(x_sim, stuck_sim)
        out["simulated_as_shipped"] = {
            cls: float(np.mean([_calls(evs[i], p_shipped[i], blocked[i])["ours"] for i in idx]))
            for cls, idx in by_class.items()
        }
        readable = ~np.array([r[3] for r in rows])
        out["measured"]["accuracy_readable"] = {
            m: float(np.mean((np.array([c[m] for c in calls]) == truth)[readable])) for m in METHODS
        }
    out["seconds"] = time.perf_counter() - t0
    return out


def print_table(fig: dict) -> None:
    print("simulated plant-like loops: share called stiction (want 100 % for stiction, 0 % for the others)")
    print(f"{'class':22s}" + "".join(f"{m:>13s}" for m in METHODS) + "      n")
    for cls, row in fig["simulated"].items():
        print(f"{cls:22s}" + "".join(f"{100 * row[m]:12.0f}%" for m in METHODS) + f"{row['n']:7d}")
    others = [r for c, r in fig["simulated"].items() if c != "stiction"]
    if others:
        print(f"{'not called (others)':22s}" + "".join(
            f"{100 * (1 - np.mean([r[m] for r in others])):12.0f}%" for m in METHODS))  # fmt: skip
    shipped = fig.get("simulated_as_shipped")
    if shipped:
        rest = [v for c, v in shipped.items() if c != "stiction"]
        print(f"ours as shipped (trained on the measured windows too): stiction {100 * shipped['stiction']:.0f} %, "
              f"others not called {100 * (1 - np.mean(rest)):.0f} %")  # fmt: skip
    print(f"evidence per window: {1000 * fig['simulated_seconds_per_loop']:.1f} ms")
    m = fig.get("measured")
    if m:
        print(f"measured windows ({m['windows']} in {m['tags']} tags, {m['sticky']} labelled sticky, "
              f"{m['bad_data']} with blocking data problems), ours cross-validated by tag:")  # fmt: skip
        for k in ("accuracy", "recall", "specificity"):
            print(f"{k:22s}" + "".join(f"{100 * m[k][x]:12.0f}%" for x in METHODS))
        print(f"{'accuracy, data readable':22s}" + "".join(f"{100 * m['accuracy_readable'][x]:12.0f}%" for x in METHODS)
              + f"   ({m['windows'] - m['bad_data']} windows: a dead or frozen sensor shows no valve)")  # fmt: skip
        print(f"ours trained on simulation only: accuracy {100 * m['accuracy_simulation_only']:.0f} %")
        print(f"measured windows within 0.1 of the threshold, cross-validated: {m['near_threshold']}"
              " (their calls may flip with small changes in training)")  # fmt: skip
    print(f"{fig['seconds']:.0f} s")
