"""Historian exports (spec/interfaces.md): CSV with a header row, columns found by their usual aliases.

Required: ``op`` and ``pv``; optional: ``t`` (seconds), ``sp``, ``mv``, ``mode``.  Without a
time column the sample time comes from ``ts_s``.  Every problem is an ``InputError``
naming the file, the row (1-based, counting the header as row 1) or the column, and
what was expected.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from schemas.errors import InputError

ALIASES = {
    "t": ["t", "t_s", "time", "time_s", "timestamp", "seconds"],
    "op": ["op", "op_pct", "out", "output", "controller_output", "cv", "mv_op"],
    "pv": ["pv", "pv_pct", "process_value", "measurement", "y"],
    "sp": ["sp", "sp_pct", "sv", "setpoint", "set_point"],
    "mv": ["mv", "mv_pct", "valve", "valve_position", "position"],
    "mode": ["mode", "auto", "man"],
}
MAX_BYTES = 200 * 1024 * 1024
GAP_TOLERANCE = 0.01
"""Relative deviation of a time step from the sample time that counts as a gap."""


@dataclass(frozen=True)
class Export:
    path: str
    op: np.ndarray
    pv: np.ndarray
    ts_s: float
    t_s: np.ndarray
    sp: np.ndarray | None
    mv: np.ndarray | None
    warnings: tuple[str, ...]


def _find(header: list[str], field: str, override: str | None, path: str) -> int | None:
    names = [h.strip() for h in header]
    if override is not None:
        if override not in names:
            raise InputError(f"{path}: no column {override!r} for {field} (columns: {', '.join(names)})")
        return names.index(override)
    lowered = [n.lower() for n in names]
    for alias in ALIASES[field]:
        if alias in lowered:
            return lowered.index(alias)
    return None


def _relabel_off_grid(t: np.ndarray) -> tuple[np.ndarray, int]:
    """Isolated rows stamped exactly one sample off the regular grid, relabelled onto it.

    Some exports round a timestamp to its neighbour's (``t, t, t + 2 Ts``, or a first
    row stamped ``0`` before ``2 Ts``): the samples are evenly spaced, the stamps are not.
    Only isolated rows (under 5 %, never two in a row) exactly one step off qualify.
    """
    if t.size < 10:
        return t, 0
    ts = float(np.median(np.diff(t)))
    if ts <= 0:
        return t, 0
    k = np.arange(t.size)
    grid = float(np.median(t - k * ts)) + k * ts
    off = np.abs(t - grid) > GAP_TOLERANCE * ts
    if not off.any() or off.mean() >= 0.05 or np.any(off[1:] & off[:-1]):
        return t, 0
    if np.any(np.abs(np.abs(t - grid)[off] - ts) > GAP_TOLERANCE * ts):
        return t, 0
    return np.where(off, grid, t), int(off.sum())


def _parse_time(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return np.datetime64(text.strip().replace("Z", ""), "ms").astype("int64") / 1000.0


def read_export(path: Path | str, ts_s: float | None = None, columns: dict[str, str] | None = None) -> Export:
    """Read one export; ``columns`` maps ``op``/``pv``/``t``/``sp``/``mv`` to the file's own names."""
    path = Path(path)
    name = str(path)
    columns = columns or {}
    if not path.is_file():
        raise InputError(f"{name}: no such file")
    if path.stat().st_size > MAX_BYTES:
        raise InputError(f"{name}: {path.stat().st_size} bytes, more than the {MAX_BYTES} a loop export may have")
    if path.suffix.lower() == ".parquet":
        rows, header = _read_parquet(path)
    else:
        try:
            with path.open(newline="", encoding="utf-8-sig") as f:
                reader = csv.reader(f)
                header = next(reader, None)
                rows = list(reader)
        except UnicodeDecodeError as e:
            raise InputError(f"{name}: not a text CSV ({e.reason} at byte {e.start})") from None
    if not header:
        raise InputError(f"{name}: empty file, expected a header row with op and pv columns")
    idx = {f: _find(header, f, columns.get(f), name) for f in ALIASES}
    for required in ("op", "pv"):
        if idx[required] is None:
            raise InputError(
                f"{name}: no {required} column (columns: {', '.join(h.strip() for h in header)}); "
                f"name it with --{required}"
            )
    if not rows:
        raise InputError(f"{name}: header only, no samples")
    values = {f: np.empty(len(rows)) for f, i in idx.items() if i is not None}
    for r, row in enumerate(rows, start=2):
        if len(row) != len(header):
            raise InputError(f"{name}: row {r} has {len(row)} fields, the header has {len(header)}")
        for f, i in idx.items():
            if i is None:
                continue
            text = row[i].strip()
            try:
                v = _parse_time(text) if f == "t" else float(text)
            except ValueError:
                raise InputError(f"{name}: row {r}, column {header[i].strip()!r}: {text!r} is not a number") from None
            if not math.isfinite(v):
                raise InputError(f"{name}: row {r}, column {header[i].strip()!r}: {text!r}, expected a finite number")
            values[f][r - 2] = v
    warnings = []
    if "t" in values:
        t = values["t"]
        step = np.diff(t)
        t, relabelled = _relabel_off_grid(t)
        if relabelled:
            warnings.append(
                f"{relabelled} timestamps sit one sample off an even grid (e.g. a repeated stamp "
                "followed by a double step): read as evenly sampled"
            )
            step = np.diff(t)
        bad = np.flatnonzero(step <= 0)
        if bad.size:
            r = bad[0] + 3
            kind = "repeats" if step[bad[0]] == 0 else "goes back from"
            raise InputError(
                f"{name}: row {r}: time {t[bad[0] + 1]:g} {kind} the row before ({t[bad[0]]:g}); "
                "samples must be in time order without duplicates"
            )
        ts_file = float(np.median(step)) if step.size else float("nan")
        gaps = np.flatnonzero(np.abs(step - ts_file) > GAP_TOLERANCE * ts_file)
        if gaps.size:
            r = gaps[0] + 3
            raise InputError(
                f"{name}: row {r}: time step {step[gaps[0]]:g} s where the file's sample time is "
                f"{ts_file:g} s; a gap or uneven sampling ({gaps.size} such steps)"
            )
        if ts_s is not None and abs(ts_s - ts_file) > GAP_TOLERANCE * ts_file:
            raise InputError(f"{name}: --ts {ts_s} s disagrees with the time column's {ts_file:g} s")
        ts = ts_file
    else:
        ts = 1.0 if ts_s is None else ts_s
        t = np.arange(len(rows)) * ts
    op = values["op"]
    if np.ptp(op) < 1.5 and op.min() >= 0 and op.max() <= 1.0 + 1e-9:
        warnings.append("op lies within 0..1: if it is a fraction, not percent, scale it by 100")
    if "mode" in values and np.ptp(values["mode"]) > 0:
        warnings.append("the mode column changes within the file: part of it may be in manual (open loop)")
    return Export(name, op, values["pv"], ts, t, values.get("sp"), values.get("mv"), tuple(warnings))


def _read_parquet(path: Path):
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise InputError(f"{path}: reading parquet needs pyarrow (pip install pyarrow)") from None
    table = pq.read_table(path)
    header = table.column_names
    cols = [table.column(c).to_pylist() for c in header]
    return [[str(v) for v in row] for row in zip(*cols, strict=True)], header
