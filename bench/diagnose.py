"""``stiction bench diagnose``: per cause, what diagnose names, how well it reads the parameter, and at what cost.

Loops: the canonical loop with one hidden effect each (``sim.grid.effect_loops``), white
noise of 1-4 % of PV's RMS on PV, OP/PV/SP only.  For every cause: how often it is named
(the confusion row), the median relative error of its parameters, how often the
extended model gains on the canonical one, fs/fd error of the canonical and of the
extended model, and CPU seconds per loop.
"""

from __future__ import annotations

import multiprocessing
import os
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from ident.diagnose import cause_parameters, diagnose
from ident.record import Record
from sim.extensions import CATALOGUE
from sim.grid import EFFECT_RANGES, effect_loops
from sim.loop import simulate

SEED = 20261122
HORIZON = int(os.environ.get("STICTION_H", "1"))


def _one(spec) -> dict:
    r = simulate([spec]).kept()
    rec = Record(r.op[0], r.pv[0], float(r.t_s[1] - r.t_s[0]), horizon=HORIZON)
    started = time.process_time()
    d = diagnose(rec)
    seconds = time.process_time() - started
    truth = spec.extensions.active()
    named = list(d.causes)
    params = cause_parameters(d.extended)
    return {
        "named": named,
        "truth": truth,
        "params": params,
        "gain_pct": d.gain_pct(rec),
        "fs_fd_base": [d.base_friction.fs_pct, d.base_friction.fd_pct],
        "fs_fd_ext": [d.friction.fs_pct, d.friction.fd_pct],
        "fs_fd_true": [spec.fs_pct, spec.fd_pct],
        "seconds": seconds,
    }


def _summary(cause: str, rows: list[dict]) -> dict:
    named = Counter(r["named"][0] if r["named"] else "none" for r in rows)
    hit = [(cause in r["named"]) if cause != "none" else not r["named"] for r in rows]
    rel = []
    for r in rows:
        for p, v in r["truth"].items():
            if p in r["params"] and np.isfinite(r["params"][p]):
                rel.append(abs(r["params"][p] - v) / abs(v))
    def mae(key):
        e = [np.mean(np.abs(np.subtract(r[key], r["fs_fd_true"]))) for r in rows]
        return float(np.nanmean(e)) if e else float("nan")

    return {
        "n": len(rows),
        "named_share": float(np.mean(hit)),
        "first_named": dict(named),
        "param_rel_err_median": float(np.median(rel)) if rel else None,
        "gain_positive_share": float(np.mean([r["gain_pct"] > 0 for r in rows])),
        "fs_fd_mae_canonical_pp": mae("fs_fd_base"),
        "fs_fd_mae_extended_pp": mae("fs_fd_ext"),
        "s_per_loop_median": float(np.median([r["seconds"] for r in rows])),
        "false_causes": dict(Counter(c for r in rows for c in r["named"] if c != cause)),
    }


def bench_diagnose(per_cause: int = 20, causes: list[str] | None = None, workers: int = 2, progress=None) -> dict:
    causes = causes or list(EFFECT_RANGES)
    specs = {c: effect_loops(c, per_cause, SEED + list(EFFECT_RANGES).index(c)) for c in causes}
    out = {}
    # one BLAS thread per worker: the figures are CPU seconds of one core per loop
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as pool:
        for c in causes:
            rows = list(pool.map(_one, specs[c]))
            out[c] = _summary(c, rows) | {"params": list(CATALOGUE.get(c, ()))}
            if progress:
                progress(c, out[c])
    return {"per_cause": out, "loops_per_cause": per_cause}
