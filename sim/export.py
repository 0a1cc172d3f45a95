"""Simulated loops as files: historian-export CSVs and the compact training-grid file.

Grid file (``.npz``, numpy's zip of arrays, compressed):

- ``fs_pct``, ``fd_pct``: ``(n,)`` float64, percent of 500 lbf
- ``t_s``: ``(m,)`` float64, the kept sample times (1000 .. 1999 for the canonical grid)
- ``op``, ``pv``, ``mv``: ``(n, m)`` float32, percent of span (deviation variables)
- ``meta``: a JSON string: loop, valve, duration_s, warmup_s, ts_s, format version
"""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

import numpy as np

from stiction.sim.loop import SimResult
from stiction.sim.valve import band_and_jump_pct

GRID_FORMAT_VERSION = 1


def truth_record(result: SimResult, i: int) -> dict:
    """What is true of loop ``i``: its friction in both conventions, disturbance and extensions."""
    spec = result.specs[i]
    s_pct, j_pct = band_and_jump_pct(spec.fs_pct, spec.fd_pct)
    return {
        "fs_pct": spec.fs_pct,
        "fd_pct": spec.fd_pct,
        "s_pct": float(s_pct),
        "j_pct": float(j_pct),
        "loop": spec.loop if spec.process is None else "own",
        "process": asdict(spec.model),
        "valve": spec.valve,
        "seed": spec.seed,
        "disturbance": None if spec.disturbance is None else asdict(spec.disturbance),
        "extensions": spec.extensions.active(),
        "causes": spec.extensions.causes(),
    }


def write_csv(path: Path, result: SimResult, i: int = 0) -> None:
    """One loop as a historian export: ``t_s, op, pv, sp, mv``."""
    columns = np.column_stack([result.t_s, result.op[i], result.pv[i], result.sp[i], result.mv[i]])
    np.savetxt(path, columns, delimiter=",", header="t_s,op,pv,sp,mv", comments="", fmt="%.9g")


def write_truth(path: Path, result: SimResult, i: int = 0) -> None:
    path.write_text(json.dumps(truth_record(result, i), indent=2) + "\n")


def write_grid(path: Path, result: SimResult, duration_s: float, warmup_s: float) -> None:
    spec0 = result.specs[0]
    meta = {
        "format_version": GRID_FORMAT_VERSION,
        "loop": spec0.loop,
        "valve": spec0.valve,
        "duration_s": duration_s,
        "warmup_s": warmup_s,
        "ts_s": float(result.t_s[1] - result.t_s[0]),
        "n_patterns": len(result.specs),
    }
    np.savez_compressed(
        path,
        fs_pct=np.array([s.fs_pct for s in result.specs]),
        fd_pct=np.array([s.fd_pct for s in result.specs]),
        t_s=result.t_s,
        op=result.op.astype(np.float32),
        pv=result.pv.astype(np.float32),
        mv=result.mv.astype(np.float32),
        meta=json.dumps(meta),
    )


def read_grid(path: Path) -> dict:
    with np.load(path) as f:
        data = {k: f[k] for k in f.files}
    data["meta"] = json.loads(str(data["meta"]))
    if data["meta"].get("format_version") != GRID_FORMAT_VERSION:
        raise ValueError(f"{path}: grid format {data['meta'].get('format_version')}, expected {GRID_FORMAT_VERSION}")
    return data
