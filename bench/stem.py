"""``stiction bench stem``: the valve checked against its measured stem (``ident.valve_check``), on simulated stems.

Each stem is driven by a plant loop's OP (``sim.plant_families``, the four families, plant-scale bands, one seed)
and is one of three: Choudhury's two-parameter valve (S log-uniform over 0.5-10 % of span, J 0-S), a linear valve,
or the thesis's physical valve (the canonical loop's own stem, ``sim.grid.random_loops``, fs 6-100 % of 500 lbf).
Each goes through an actuator lag of 0-3 samples, is stored a sample after its OP or with it (how a historian
stamps them is not known), with a calibration (gain 0.9-1.1, offset up to 2 %), noise of 0.02-0.3 % and, every
other one, steps of 0.1 %.  The bench prints, by kind, the share called sticky, and for the sticky ones how often the
truth lies within two of the reported errors and the median relative error of S; a stem whose OP never travels twice
its band cannot show it, and is counted apart.
"""

from __future__ import annotations

import time

import numpy as np

KINDS = ("two_parameter", "physical", "linear")


def _stems(n: int, seed: int) -> list[dict]:
    """``n`` stems of each kind: (op, mv, ts_s) and the truth."""
    from stiction.ident.stem_fit import lagged, path
    from stiction.sim.grid import random_loops
    from stiction.sim.loop import simulate
    from stiction.sim.plant_families import family_loops, simulate_families, stable
    from stiction.sim.valve import band_and_jump_pct

    rng = np.random.default_rng(seed)
    loops = family_loops(max(1, -(-2 * n // 44)), seed, bands="plant")
    ops = [(r.op, r.ts_s) for r in simulate_families(loops) if stable(r) and np.ptp(r.op) > 0]
    rng.shuffle(ops)
    canonical = random_loops(n, seed + 1)
    run = simulate(canonical).kept()
    out = []
    for i in range(n):
        for kind in KINDS:
            if kind == "physical":
                op, valve, ts_s = run.op[i], run.mv[i], 1.0
                s, j = (float(v) for v in band_and_jump_pct(canonical[i].fs_pct, canonical[i].fd_pct))
            else:
                op, ts_s = ops[(2 * i + (kind == "linear")) % len(ops)]
                drive = lagged(op, np.array([rng.uniform(0.0, 3.0) * ts_s]), ts_s)[0]
                s = float(np.exp(rng.uniform(np.log(0.5), np.log(10.0)))) if kind == "two_parameter" else 0.0
                j = s * float(rng.uniform(0.0, 1.0))
                valve = path(drive, s, j) if s > 0 else drive.copy()  # Choudhury's valve (sim.two_parameter's step)
                if rng.random() < 0.5:  # stored a sample after the OP that moved it
                    valve = np.concatenate([valve[:1], valve[:-1]])
            mv = float(rng.uniform(-2.0, 2.0)) + float(rng.uniform(0.9, 1.1)) * valve
            mv = mv + float(rng.uniform(0.02, 0.3)) * rng.standard_normal(mv.size)
            if rng.random() < 0.5:
                mv = np.round(mv / 0.1) * 0.1
            out.append({"kind": kind, "op": np.asarray(op, float), "mv": mv, "ts_s": ts_s, "s": s, "j": j})
    return out


def bench_stem(n: int = 30, seed: int = 2718) -> dict:
    from stiction.ident.valve_check import check_valve

    rows = []
    for stem in _stems(n, seed):
        started = time.process_time()
        v = check_valve(stem["op"], stem["mv"], stem["ts_s"])
        readable = bool(np.ptp(stem["op"]) >= 2 * stem["s"])
        rows.append({"kind": stem["kind"], "s": stem["s"], "j": stem["j"], "readable": readable, "sticky": v.sticky,
                     "s_read": v.s_pct, "j_read": v.j_pct, "s_se": v.s_se_pct, "j_se": v.j_se_pct, "valve": v.valve,
                     "cpu_s": time.process_time() - started})  # fmt: skip
    out: dict = {"stems_per_kind": n, "seed": seed, "kinds": {}}
    for kind in KINDS:
        mine = [r for r in rows if r["kind"] == kind]
        readable = [r for r in mine if r["readable"]]
        called = [r for r in mine if r["sticky"]]
        row = {
            "n": len(mine),
            "called_sticky": float(np.mean([r["sticky"] for r in mine])),
            "readable": len(readable),
            "called_sticky_readable": float(np.mean([r["sticky"] for r in readable])) if readable else None,
            "cpu_s_median": float(np.median([r["cpu_s"] for r in mine])),
        }
        if kind != "linear" and called:
            row |= {
                "s_within_2se": float(np.mean([abs(r["s_read"] - r["s"]) <= 2 * r["s_se"] for r in called])),
                "j_within_2se": float(np.mean([abs(r["j_read"] - r["j"]) <= 2 * r["j_se"] for r in called])),
                "s_error_median": float(np.median([abs(r["s_read"] / r["s"] - 1) for r in called])),
                "read_as_two_parameter": float(np.mean([r["valve"] == "two_parameter" for r in called])),
            }
        out["kinds"][kind] = row
    return out


def print_table(fig: dict) -> None:
    print(f"the valve against its measured stem (ident.valve_check): {fig['stems_per_kind']} stems of each kind, "
          f"seed {fig['seed']}")  # fmt: skip
    print("kind            called sticky  (OP travelled 2 S)  S within 2 se  J within 2 se  |S error| median  CPU s")
    for kind, r in fig["kinds"].items():
        def pct(x):
            return "-" if x is None else f"{100 * x:.0f} %"

        print(f"{kind:15s} {pct(r['called_sticky']):>13s}  {pct(r['called_sticky_readable']):>18s}  "
              f"{pct(r.get('s_within_2se')):>13s}  {pct(r.get('j_within_2se')):>13s}  "
              f"{pct(r.get('s_error_median')):>16s}  {r['cpu_s_median']:5.2f}")  # fmt: skip
