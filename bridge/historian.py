"""Historian exports (spec/interfaces.md): a header row, columns found by their usual aliases.

Required: ``op`` and ``pv``; optional: ``t`` (seconds or ISO 8601 times), ``sp``, ``mv``,
``mode``.  Without a time column the sample time comes from ``ts_s``.  The format, separator
and decimal mark are read from the content (``bridge.dialect``).  Files are read in blocks and
only the window asked for is kept (``last`` samples, or one window every ``every`` samples), so
memory follows the window, not the file.  Every problem is an ``InputError`` naming the file,
the row (1-based, counting the header as row 1) or the column, and what was expected; but a gap or two in the
time column (``UNEVEN_SHARE``) is a warning: ``read_export`` fills the short ones in (``FILL_SHARE``) and keeps the
samples after the last long one, and the windows of ``read_windows`` start afresh after each.
"""

from __future__ import annotations

import csv
import itertools
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from stiction.bridge.cells import (
    ALIASES,
    GAP_TOLERANCE,
    blank,
    find_column,
    finite,
    modes,
    numbers,
    relabel_off_grid,
    row_numbers,
)
from stiction.bridge.dialect import Dialect, sniff
from stiction.schemas.errors import InputError

EXPORT_SUFFIXES = (".csv", ".txt", ".tsv", ".parquet", ".pq")
MAX_BYTES = 4 * 1024**3
"""Larger files are refused unread (they are read in blocks, so this bounds time, not memory)."""
BLOCK_ROWS = 65536
FILL_SHARE = 0.1
"""A gap of at most this share of the window's samples is filled in by linear interpolation, as the agent bridges a
short gap in a stream (``agent.core.CoreSettings.fill_limit``: a tenth of its window); a longer one cuts the window."""
UNEVEN_SHARE = 0.01
"""A file with time steps off its sample time at more than this share of its samples is unevenly sampled, not a record
with a gap or two, and is refused; with fewer, ``read_export`` reads the stretch after the last gap."""


@dataclass(frozen=True)
class Export:
    """One window of an export: the samples kept, and which rows of the file they are."""

    path: str
    op: np.ndarray
    pv: np.ndarray
    ts_s: float
    t_s: np.ndarray
    sp: np.ndarray | None
    mv: np.ndarray | None
    warnings: tuple[str, ...]
    mode: np.ndarray | None = None
    first_row: int = 2
    """File row of the first sample kept (the header is row 1)."""
    rows_in_file: int | None = None
    """Samples in the whole file (None until the file has been read to its end)."""
    interpolated: int = 0
    """Samples filled in by linear interpolation across short gaps in the time column (``FILL_SHARE``)."""
    gap_note: str | None = None
    """What gaps in the time column did to this window (the first of ``warnings``), or None."""

    @property
    def last_row(self) -> int:
        return self.first_row + self.op.size - self.interpolated - 1


def expand_paths(paths: Sequence[Path]) -> list[Path]:
    """Paths as given, each folder replaced by the exports in it (by suffix, sorted); a folder
    with none stays as it is so that reading it says so."""
    out: list[Path] = []
    for p in paths:
        p = Path(p)
        found = []
        if p.is_dir():
            found = sorted(f for f in p.iterdir() if f.is_file() and f.suffix.lower() in EXPORT_SUFFIXES)
        out.extend(found or [p])
    return out


def read_export(
    path: Path | str,
    ts_s: float | None = None,
    columns: dict[str, str] | None = None,
    last: int | None = None,
    pv_span: tuple[float, float] | None = None,
) -> Export:
    """Read one export, keeping its last ``last`` samples (all when None); ``columns`` maps
    ``op``/``pv``/``t``/``sp``/``mv``/``mode`` to the file's own names; ``pv_span``: PV's (and SP's)
    engineering range (``pv_to_percent``), where the file does not record them in percent of span."""
    reader = _Reader(path, ts_s, columns, pv_span)
    reader.gaps_allowed = True
    tail = _Tail(last)
    for block in reader.blocks():
        tail.add(block)
        if last is not None:
            reader.forget_gaps(tail.seen - last)
    window = tail.window()
    if window is None:
        raise InputError(f"{reader.name}: header only, no samples")
    return reader.export_mended(window, tail.seen)


def read_windows(
    path: Path | str,
    length: int,
    every: int,
    ts_s: float | None = None,
    columns: dict[str, str] | None = None,
    pv_span: tuple[float, float] | None = None,
) -> Iterator[Export]:
    """Windows of ``length`` samples, one ending every ``every`` samples from the first full one,
    and a last one ending at the file's end; a file shorter than ``length`` gives one window of
    all its samples.  No window spans a gap in the time column: after one they start afresh (the first
    ending ``length`` samples after it), as the agent's rolling window does, and the first says so."""
    if length < 1 or every < 1:
        raise InputError(f"window of {length} samples every {every}: both must be at least 1")
    reader = _Reader(path, ts_s, columns, pv_span)
    reader.gaps_allowed = True
    tail = _Tail(length)
    next_end, floor, last_end, told, note = length, 0, 0, 0, None

    def window(end: int) -> Export:
        nonlocal last_end, note
        export, last_end, note = reader.export(tail.window(end=end), None, gap_note=note), end, None
        return export

    for block in reader.blocks():
        tail.add(block, keep_from=max(floor, next_end - length))
        for row, start, step in reader.gaps[told:]:
            while next_end <= start:  # the windows that end before the gap
                yield window(next_end)
                next_end += every
            reader.uneven(tail.seen)
            floor, next_end = start, start + length
            note = (
                f"a gap in the time column at row {row} (a step of {step:g} s where the sample time is "
                f"{reader.ts:g} s): the windows start afresh after it"
            )
        while tail.seen >= next_end:
            yield window(next_end)
            next_end += every
        reader.forget_gaps(tail.seen - length)
        told = len(reader.gaps)
    if tail.seen == 0:
        raise InputError(f"{reader.name}: header only, no samples")
    if tail.seen > last_end:  # a short file, or the newest samples since the last window
        yield reader.export_mended(tail.window(), tail.seen)


@dataclass
class _Block:
    first: int  # index of the block's first sample in the file (0-based)
    values: dict[str, np.ndarray]


class _Tail:
    """The last ``keep`` samples of a stream of blocks (all when ``keep`` is None)."""

    def __init__(self, keep: int | None):
        self.keep, self.seen, self.blocks = keep, 0, []

    def add(self, block: _Block, keep_from: int | None = None) -> None:
        self.blocks.append(block)
        self.seen = block.first + next(iter(block.values.values())).size
        if self.keep is None:
            return
        start = self.seen - self.keep if keep_from is None else min(keep_from, self.seen - self.keep)
        while len(self.blocks) > 1 and self.blocks[1].first <= start:
            self.blocks.pop(0)

    def window(self, end: int | None = None) -> _Block | None:
        if not self.blocks:
            return None
        end = self.seen if end is None else end
        start = self.blocks[0].first if self.keep is None else max(self.blocks[0].first, end - self.keep)
        used = [b for b in self.blocks if b.first < end and b.first + b.values["op"].size > start]
        first = used[0].first
        values = {f: np.concatenate([b.values[f] for b in used])[start - first : end - first] for f in used[0].values}
        return _Block(start, values)


PERCENT_SLACK = 5.0
"""How far outside 0-100 a signal in percent of span may read (a transmitter's over- and under-range)."""


def _filled(values: dict[str, np.ndarray], ts_s: float) -> tuple[dict[str, np.ndarray], int]:
    """A stretch's samples on its even time grid: those the time column skips filled in by linear interpolation (a
    mode held from the sample before); and how many were filled."""
    t = values["t"]
    grid = t[0] + ts_s * np.arange(int(round((t[-1] - t[0]) / ts_s)) + 1)
    if grid.size <= t.size:
        return values, 0
    out = {}
    for f, x in values.items():
        if f == "t":
            out[f] = grid
        elif f == "mode":
            out[f] = x[np.clip(np.searchsorted(t, grid + 1e-9 * ts_s, side="right") - 1, 0, t.size - 1)]
        else:
            out[f] = np.interp(grid, t, x)
    return out, grid.size - t.size


EPOCH_FROM_S = 1e8
"""A time from this many seconds on is a calendar time (seconds since 1970: 1973 onwards), said as one."""


def _stamp(t_s: float) -> str:
    """A time as the file gave it: a calendar time in ISO form (UTC), seconds as a number."""
    if abs(t_s) >= EPOCH_FROM_S:
        return str(np.datetime64(int(round(t_s * 1000)), "ms")).replace(".000", "")
    return f"{t_s:g}"


def check_span(span: tuple[float, float] | None, what: str = "--pv-span") -> tuple[float, float] | None:
    """``span`` as (low, high) of an engineering range, or an error naming what is wrong with it."""
    if span is None:
        return None
    lo, hi = (float(v) for v in span)
    if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
        raise InputError(f"{what} {lo:g} {hi:g}: expected the range's low and high ends, low below high")
    return lo, hi


def pv_to_percent(x: np.ndarray, span: tuple[float, float]) -> np.ndarray:
    """Values in engineering units over ``span`` (the transmitter's range: low, high) as percent of it."""
    lo, hi = span
    return (np.asarray(x, float) - lo) * (100.0 / (hi - lo))


def _outside_percent(x: np.ndarray) -> bool:
    """Whether ``x`` runs outside 0-100 by more than ``PERCENT_SLACK``: not percent of span."""
    return bool(x.min() < -PERCENT_SLACK or x.max() > 100.0 + PERCENT_SLACK)


class _Reader:
    """One export read block by block, time checked across blocks."""

    def __init__(
        self,
        path: Path | str,
        ts_s: float | None,
        columns: dict[str, str] | None,
        pv_span: tuple[float, float] | None = None,
    ):
        self.path = Path(path)
        self.name = str(path)
        self.ts_flag = ts_s
        self.columns = columns or {}
        self.pv_span = check_span(pv_span)
        if self.path.is_dir():
            raise InputError(f"{self.name}: a folder with no exports ({', '.join(EXPORT_SUFFIXES)}) in it")
        if not self.path.is_file():
            raise InputError(f"{self.name}: no such file")
        size = self.path.stat().st_size
        if size > MAX_BYTES:
            raise InputError(f"{self.name}: {size} bytes, more than the {MAX_BYTES} a loop export may have")
        if size == 0:
            raise InputError(f"{self.name}: empty file, expected a header row with op and pv columns")
        self.dialect: Dialect = sniff(self.path)
        self.ts: float | None = None
        self.last_t: float | None = None
        self.relabelled = 0
        self.open_loop_words: set[str] = set()
        """The mode column's words that meant an open loop (``cells.MODE_WORDS``); empty where it holds numbers."""
        self.gaps_allowed = False
        """``read_export`` reads past gaps (the stretch after the last one is kept); windows every N samples do not."""
        self.gaps: list[tuple[int, int, float]] = []
        """The gaps a window may still hold: (file row, index of the sample after it, the step [s]); older ones are
        forgotten as the reader moves on (``forget_gaps``), counted in ``gap_count`` and kept at the ends."""
        self.gap_count = 0
        self.first_gap: tuple[int, int, float] | None = None
        self.last_gap: tuple[int, int, float] | None = None

    # -- blocks ---------------------------------------------------------------------------------

    def blocks(self) -> Iterator[_Block]:
        source = self._parquet_blocks() if self.dialect.format == "parquet" else self._csv_blocks()
        for block in source:
            self._time(block)
            yield block

    def _columns(self, header: list[str]) -> dict[str, int]:
        self.header = [h.strip() for h in header]
        idx = {f: find_column(self.header, f, self.columns.get(f), self.name) for f in ALIASES}
        for required in ("op", "pv"):
            if idx[required] is None:
                raise InputError(
                    f"{self.name}: no {required} column (columns: {', '.join(self.header)}; read as "
                    f"{self.dialect.describe()}); name it with --{required}"
                )
        return {f: i for f, i in idx.items() if i is not None}

    def _csv_blocks(self) -> Iterator[_Block]:
        d = self.dialect
        with self.path.open(newline="", encoding=d.encoding, errors="strict") as f:
            reader = csv.reader(f, delimiter=d.separator)
            try:
                header = next(reader, None)
                if not header:
                    raise InputError(f"{self.name}: empty file, expected a header row with op and pv columns")
                idx = self._columns(header)
                first = 0
                while True:
                    line_before = reader.line_num
                    rows = list(itertools.islice(reader, BLOCK_ROWS))
                    if not rows:
                        return
                    rownums = None
                    if any(map(blank, rows)) or reader.line_num - line_before != len(rows):
                        rownums = row_numbers(rows, line_before)
                        rows = [r for r in rows if not blank(r)]
                        if not rows:
                            continue
                    values = self._parse_rows(rows, idx, first, rownums)
                    yield _Block(first, values)
                    first += len(rows)
            except UnicodeDecodeError as e:
                raise InputError(f"{self.name}: not a text CSV ({e.reason} after row {reader.line_num})") from None
            except csv.Error as e:
                raise InputError(f"{self.name}: row {reader.line_num}: {e}") from None

    def _parse_rows(self, rows, idx, first, rownums) -> dict[str, np.ndarray]:
        width = len(self.header)

        def row_of(k: int) -> int:
            return rownums[k] if rownums is not None else first + k + 2

        lengths = np.fromiter(map(len, rows), dtype=np.int64, count=len(rows))
        bad = np.flatnonzero(lengths != width)
        if bad.size:
            k = int(bad[0])
            raise InputError(f"{self.name}: row {row_of(k)} has {lengths[k]} fields, the header has {width}")
        values = {}
        for field, i in idx.items():
            texts = [r[i] for r in rows]
            values[field] = self._cells(field, self.header[i], texts, row_of)
        return values

    def _cells(self, field: str, column: str, texts: list, row_of) -> np.ndarray:
        """A column's text cells as numbers; a mode column's words as ``cells.MODE_WORDS`` reads them."""
        if field != "mode":
            return numbers(self.name, field, column, texts, self.dialect.decimal, row_of)
        codes, open_loop = modes(self.name, column, texts, self.dialect.decimal, row_of)
        self.open_loop_words |= open_loop
        return codes

    def _parquet_blocks(self) -> Iterator[_Block]:
        try:
            import pyarrow.parquet as pq
        except ImportError:
            raise InputError(f"{self.name}: reading Parquet needs pyarrow (pip install pyarrow)") from None
        try:
            pf = pq.ParquetFile(self.path)
            idx = self._columns(list(pf.schema_arrow.names))
            wanted = {f: self.header[i] for f, i in idx.items()}
            first = 0
            for batch in pf.iter_batches(batch_size=BLOCK_ROWS, columns=list(dict.fromkeys(wanted.values()))):
                n = batch.num_rows
                if n == 0:
                    continue
                values = {}
                for field, column in wanted.items():
                    values[field] = self._parquet_column(field, column, batch.column(column), first)
                yield _Block(first, values)
                first += n
        except InputError:
            raise
        except Exception as e:  # pyarrow's errors: a damaged or truncated file
            raise InputError(f"{self.name}: not a readable Parquet file ({str(e).splitlines()[0][:120]})") from None

    def _parquet_column(self, field: str, column: str, arr, first: int) -> np.ndarray:
        import pyarrow as pa

        def row_of(k: int) -> int:
            return first + k + 2

        if arr.null_count:
            k = int(np.flatnonzero(np.asarray(arr.is_null()))[0])
            raise InputError(f"{self.name}: row {row_of(k)}, column {column!r}: empty, expected a finite number")
        if pa.types.is_timestamp(arr.type) or pa.types.is_date(arr.type):
            return arr.cast(pa.timestamp("ms")).to_numpy().astype(np.int64) / 1000.0
        if pa.types.is_string(arr.type) or pa.types.is_large_string(arr.type):
            return self._cells(field, column, arr.to_pylist(), row_of)
        try:
            x = arr.to_numpy(zero_copy_only=False).astype(np.float64)
        except (TypeError, ValueError, pa.ArrowInvalid):
            raise InputError(f"{self.name}: column {column!r} is {arr.type}, expected numbers") from None
        finite(self.name, x, column, x, row_of)
        return x

    # -- time -----------------------------------------------------------------------------------

    def _time(self, block: _Block) -> None:
        """Check time order and spacing within the block and across the previous one."""
        t = block.values.get("t")
        if t is None:
            return
        t, relabelled = relabel_off_grid(t)
        self.relabelled += relabelled
        block.values["t"] = t
        if self.ts is None and t.size > 1:
            self.ts = float(np.median(np.diff(t)))
        joined = t if self.last_t is None else np.concatenate([[self.last_t], t])
        offset = block.first + (2 if self.last_t is None else 1)  # file row of joined[0]
        step = np.diff(joined)
        bad = np.flatnonzero(step <= 0)
        if bad.size:
            k = int(bad[0])
            kind = "repeats" if step[k] == 0 else "goes back from"
            raise InputError(
                f"{self.name}: row {offset + k + 1}: time {_stamp(joined[k + 1])} {kind} the row before "
                f"({_stamp(joined[k])}); samples must be in time order without duplicates"
            )
        if self.ts is not None:
            gaps = np.flatnonzero(np.abs(step - self.ts) > GAP_TOLERANCE * self.ts)
            if gaps.size and not self.gaps_allowed:
                raise self._gap_error(offset + int(gaps[0]) + 1, float(step[gaps[0]]), gaps.size)
            first = block.first - (0 if self.last_t is None else 1)  # file sample index of joined[0]
            found = [(offset + int(k) + 1, first + int(k) + 1, float(step[k])) for k in gaps]
            if found:
                self.gaps += found
                self.gap_count += len(found)
                self.first_gap, self.last_gap = self.first_gap or found[0], found[-1]
        self.last_t = float(t[-1])

    def _gap_error(self, row: int, step_s: float, count: int) -> InputError:
        return InputError(
            f"{self.name}: row {row}: time step {step_s:g} s where the file's sample time is {self.ts:g} s; a gap or "
            f"uneven sampling ({count} such steps)"
        )

    def uneven(self, samples: int) -> None:
        """Refuses a file whose time steps are off its sample time at more than ``UNEVEN_SHARE`` of its ``samples``
        read so far: uneven sampling, not a gap or two."""
        if self.gap_count > max(1, UNEVEN_SHARE * samples):
            row, _, step = self.first_gap
            raise self._gap_error(row, step, self.gap_count)

    def forget_gaps(self, before: int) -> None:
        """Drops the gaps no window will hold: those whose next sample is at index ``before`` or earlier (an
        unevenly sampled file of millions of rows would hold a gap for every few)."""
        if self.gaps and self.gaps[0][1] <= before:
            self.gaps = [g for g in self.gaps if g[1] > before]

    def export_mended(self, window: _Block, rows_in_file: int) -> Export:
        """``window`` as an ``Export`` after ``after_gaps``: short gaps filled, cut at the long ones, the note first."""
        window, note, filled = self.after_gaps(window, rows_in_file)
        return self.export(window, rows_in_file, filled, note)

    def after_gaps(self, window: _Block, samples: int) -> tuple[_Block, str | None, int]:
        """``window`` (the file's last samples) with its short gaps filled in (``FILL_SHARE``) and cut to its longest
        stretch between longer ones (the latest of equals: after the last, unless a gap late in the window leaves
        less there than before it); what was done, and how many samples were filled in.  A file whose time steps are
        off its sample time more than now and then (``UNEVEN_SHARE``) is refused."""
        if not self.gap_count:
            return window, None, 0
        self.uneven(samples)
        end = window.first + window.values["op"].size
        inside = [g for g in self.gaps if window.first < g[1] < end]
        said = f"{self.gap_count} gap{'s' if self.gap_count > 1 else ''} in the time column"
        if not inside:
            row, _, step = self.last_gap
            return window, said + f", the last at row {row} (a step of {step:g} s): before the samples read", 0
        limit = max(1, int(FILL_SHARE * window.values["op"].size))
        long = [g for g in inside if round(g[2] / self.ts) - 1 > limit]
        bounds = [window.first, *(g[1] for g in long), end]
        k = max(range(len(bounds) - 1), key=lambda i: (bounds[i + 1] - bounds[i], i))  # the longest, latest of equals
        a, b = bounds[k], bounds[k + 1]
        values, filled = _filled({f: x[a - window.first : b - window.first] for f, x in window.values.items()}, self.ts)
        parts = []
        if long:
            where = ", ".join(f"row {row} (a step of {step:g} s where the sample time is {self.ts:g} s)"
                              for row, _, step in long[-3:])  # fmt: skip
            which = (
                "after the last long gap"
                if k == len(bounds) - 2
                else f"of the longest stretch between long gaps (after the last, only {end - bounds[-2]})"
            )
            parts.append(f"at {where}: only the {b - a} samples {which} are read")
        if filled:
            short = sum(a < g[1] < b for g in inside)
            gaps = f"{short} short gap{'s' if short > 1 else ''}"
            parts.append(f"{filled} samples filled in by linear interpolation across {gaps} (at most a tenth of the "
                         "window each, as the agent does)")  # fmt: skip
        return _Block(a, values), said + (" " if long else ": ") + "; ".join(parts), filled

    # -- the window as an Export ----------------------------------------------------------------

    def export(
        self, block: _Block, rows_in_file: int | None, interpolated: int = 0, gap_note: str | None = None
    ) -> Export:
        v = block.values
        n = v["op"].size
        notes = [] if gap_note is None else [gap_note]
        if "t" in v:
            ts = self.ts if self.ts is not None else (1.0 if self.ts_flag is None else self.ts_flag)
            if self.ts_flag is not None and abs(self.ts_flag - ts) > GAP_TOLERANCE * ts:
                raise InputError(f"{self.name}: --ts {self.ts_flag} s disagrees with the time column's {ts:g} s")
            t = v["t"]
        else:
            ts = 1.0 if self.ts_flag is None else self.ts_flag
            t = (block.first + np.arange(n)) * ts
        if not (math.isfinite(ts) and ts > 0):
            raise InputError(f"{self.name}: sample time {ts} s, expected a positive number")
        if self.relabelled:
            notes.append(
                f"{self.relabelled} timestamps sit one sample off an even grid (e.g. a repeated stamp "
                "followed by a double step): read as evenly sampled"
            )
        op = v["op"]
        if np.ptp(op) < 1.5 and op.min() >= 0 and op.max() <= 1.0 + 1e-9:
            notes.append("op lies within 0..1: if it is a fraction, not percent, scale it by 100")
        elif _outside_percent(op):
            notes.append(
                f"op runs from {op.min():.4g} to {op.max():.4g}, outside 0-100: not percent of span? "
                "S and J are read in OP's own units"
            )
        pv, sp = v["pv"], v.get("sp")
        if self.pv_span is not None:
            pv = pv_to_percent(pv, self.pv_span)
            sp = None if sp is None else pv_to_percent(sp, self.pv_span)
            lo, hi = self.pv_span
            notes.append(f"pv{' and sp' if sp is not None else ''} read over {lo:g}-{hi:g} (--pv-span) as percent")
        if _outside_percent(pv):
            span = (
                "outside the --pv-span given."
                if self.pv_span is not None
                else "engineering units? (--pv-span LO HI reads them as percent of that range)."
            )
            notes.append(
                f"pv runs from {pv.min():.4g} to {pv.max():.4g}, outside 0-100: {span} The verdict "
                "and an identified process read PV in any units; the canonical level process (--process level) "
                "assumes percent of span, and a process gain is read per percent of PV"
            )
        if "mode" in v and self.open_loop_words and np.any(v["mode"] == 0.0):
            open_loop, words = int(np.count_nonzero(v["mode"] == 0.0)), ", ".join(sorted(self.open_loop_words))
            notes.append(
                f"the mode column says the controller did not drive the valve ({words}) on {open_loop} of the {n} "
                "samples analysed: an open loop there, whose OP is not the controller's"
            )
        elif "mode" in v and np.ptp(v["mode"]) > 0:
            notes.append("the mode column changes within the file: part of it may be in manual (open loop)")
        rows = n - interpolated  # the file's rows among the samples
        if (rows_in_file is not None and rows < rows_in_file) or block.first > 0:
            of = f"{rows} of {rows_in_file} samples" if rows_in_file is not None else f"{rows} samples"
            notes.append(f"rows {block.first + 2}-{block.first + rows + 1} of the file analysed ({of})")
        return Export(
            self.name,
            op,
            pv,
            float(ts),
            t,
            sp,
            v.get("mv"),
            tuple(notes),
            v.get("mode"),
            block.first + 2,
            rows_in_file,
            interpolated,
            gap_note,
        )
