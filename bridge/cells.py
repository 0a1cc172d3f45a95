"""A historian export's cells: the header's columns found by their usual aliases, values read as
numbers (decimal commas, ISO 8601 times) and every bad one named by file, row and column;
timestamps one sample off the regular grid put back on it.  Pure: no files (``bridge.historian``
reads them)."""

from __future__ import annotations

import warnings as _warnings

import numpy as np

from stiction.schemas.errors import InputError

GAP_TOLERANCE = 0.01
"""Relative deviation of a time step from the sample time that counts as a gap."""
ALIASES = {
    "t": ["t", "t_s", "time", "time_s", "timestamp", "seconds"],
    "op": ["op", "op_pct", "out", "output", "controller_output", "cv", "mv_op"],
    "pv": ["pv", "pv_pct", "process_value", "measurement", "y"],
    "sp": ["sp", "sp_pct", "sv", "setpoint", "set_point"],
    "mv": ["mv", "mv_pct", "valve", "valve_position", "position"],
    "mode": ["mode", "auto", "man"],
}


MODE_WORDS = {
    **dict.fromkeys(("auto", "aut", "automatic", "a", "cas", "cascade", "rcas"), 1.0),
    **dict.fromkeys(("man", "manual", "m", "iman", "lo", "rout", "oos", "trk", "track"), 0.0),
}
"""Controller modes as control systems write them (AUTO, MAN, CAS, RCAS, ROUT, IMAN, LO, OOS), case ignored: 1 where
the loop's own controller drives the valve (a closed loop), 0 where it does not (manual, an output set from outside,
a tracked or initialising output, out of service: an open loop)."""


def modes(name: str, column: str, texts: list, decimal: str, row_of) -> tuple[np.ndarray, frozenset[str]]:
    """A mode column as numbers, as recorded (``numbers``), or, where it holds words, each word's ``MODE_WORDS`` value
    and the words that meant an open loop (so that a report can say when the controller was not driving the valve)."""
    try:
        return numbers(name, "mode", column, texts, decimal, row_of), frozenset()
    except InputError:
        words = [str(s).strip().lower() for s in texts]
        known = [w in MODE_WORDS for w in words]
        if not any(known):
            raise
    if not all(known):
        k = known.index(False)
        raise InputError(
            f"{name}: row {row_of(k)}, column {column!r}: {texts[k]!r} is no controller mode this reader knows "
            f"(numbers as recorded, or {', '.join(w.upper() for w in MODE_WORDS if len(w) > 1)})"
        )
    codes = np.array([MODE_WORDS[w] for w in words])
    return codes, frozenset(w.upper() for w, c in zip(words, codes, strict=True) if c == 0.0)


def blank(row: list[str]) -> bool:
    """A row with no value in it: an empty line, or separators alone (``,,,``, as spreadsheets end an export)."""
    return not any(cell.strip() for cell in row)


def numbers(name: str, field: str, column: str, texts: list, decimal: str, row_of) -> np.ndarray:
    """A column's cells as numbers (``t`` may hold ISO 8601 times), every bad cell an ``InputError``
    naming the file, its row (``row_of``: block index to file row) and column."""
    raw = texts
    if decimal == ",":
        texts = [s.replace(",", ".") for s in texts]
    try:
        x = np.array(texts, dtype=np.float64)
    except ValueError:
        x = time_strings(name, raw, column, row_of) if field == "t" else None
        if x is None:
            for k, s in enumerate(texts):
                try:
                    float(s)
                except ValueError:
                    what = "an empty field" if not s.strip() else "not a number"
                    raise InputError(f"{name}: row {row_of(k)}, column {column!r}: {raw[k]!r} is {what}") from None
    finite(name, x, column, raw, row_of)
    return x


def time_strings(name: str, texts: list[str], column: str, row_of) -> np.ndarray | None:
    """ISO 8601 times as seconds, or None when the first unreadable value is not a time either."""
    with _warnings.catch_warnings():
        _warnings.simplefilter("ignore")  # numpy warns that a UTC offset has no representation
        try:
            stamps = np.array([s.strip().replace("Z", "") for s in texts], dtype="datetime64[ms]")
        except ValueError:
            for k, s in enumerate(texts):
                try:
                    float(s)
                except ValueError:
                    try:
                        np.datetime64(s.strip().replace("Z", ""), "ms")
                    except ValueError:
                        raise InputError(
                            f"{name}: row {row_of(k)}, column {column!r}: {s!r} is neither seconds nor an ISO 8601 time"
                        ) from None
            return None
    if np.isnat(stamps).any():
        k = int(np.flatnonzero(np.isnat(stamps))[0])
        raise InputError(f"{name}: row {row_of(k)}, column {column!r}: {texts[k]!r} is not a time")
    return stamps.astype(np.int64) / 1000.0


def finite(name: str, x: np.ndarray, column: str, raw, row_of) -> None:
    bad = np.flatnonzero(~np.isfinite(x))
    if bad.size:
        k = int(bad[0])
        raise InputError(
            f"{name}: row {row_of(k)}, column {column!r}: {str(raw[k])!r}, expected a finite number "
            f"({bad.size} such values in rows {row_of(k)}-{row_of(int(bad[-1]))})"
        )
    big = np.flatnonzero(np.abs(x) > 1e12)
    if big.size and column.lower() not in ALIASES["t"]:
        k = int(big[0])
        raise InputError(
            f"{name}: row {row_of(k)}, column {column!r}: {str(raw[k])!r} is no percent of span "
            "(more than 1e12 in size); expected values of about 0-100"
        )


def row_numbers(rows: list[list[str]], line_before: int) -> list[int]:
    """File rows of the non-blank rows of a block (``blank`` rows skipped); quoted line breaks are
    not expected in numeric exports, so each row is one line."""
    out, line = [], line_before
    for r in rows:
        line += 1
        if not blank(r):
            out.append(line)
    return out


def find_column(header: list[str], field: str, override: str | None, path: str) -> int | None:
    if override is not None:
        if override not in header:
            raise InputError(f"{path}: no column {override!r} for {field} (columns: {', '.join(header)})")
        return header.index(override)
    lowered = [n.lower() for n in header]
    for alias in ALIASES[field]:
        if alias in lowered:
            return lowered.index(alias)
    return None


def relabel_off_grid(t: np.ndarray) -> tuple[np.ndarray, int]:
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
