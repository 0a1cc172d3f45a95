"""How an export is written, read from its content (never its name): Parquet or text, and a text
file's separator and decimal mark.

Plants write CSV as their historian and locale make it: ``,`` with a decimal point, ``;`` with a
decimal comma (European historians), tab- or ``|``-separated.  The separator is the candidate
that splits the header into the most fields and every sampled data row into as many; the decimal
mark is a comma when numbers like ``12,5`` appear and ``12.5`` do not (only with a separator
other than ``,``).
"""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from pathlib import Path

from stiction.schemas.errors import InputError

PARQUET_MAGIC = b"PAR1"
SEPARATORS = (",", ";", "\t", "|")
SNIFF_BYTES = 64 * 1024
SNIFF_ROWS = 50
_COMMA_DECIMAL = re.compile(r"^\s*[-+]?\d+,\d+([eE][-+]?\d+)?\s*$")
_POINT_DECIMAL = re.compile(r"^\s*[-+]?\d*\.\d+([eE][-+]?\d+)?\s*$")
_NUMBER = re.compile(r"^\s*[-+]?(\d+([.,]\d*)?|[.,]\d+)([eE][-+]?\d+)?\s*$")
_NAMES = {",": "','", ";": "';'", "\t": "tab", "|": "'|'"}


@dataclass(frozen=True)
class Dialect:
    format: str  # "csv" or "parquet"
    separator: str = ","
    decimal: str = "."
    encoding: str = "utf-8-sig"

    def describe(self) -> str:
        if self.format == "parquet":
            return "Parquet"
        return f"text separated by {_NAMES[self.separator]}, decimal {'comma' if self.decimal == ',' else 'point'}"


def sniff(path: Path) -> Dialect:
    """The export's format, separator and decimal mark, or an InputError naming what is wrong."""
    name = str(path)
    with path.open("rb") as f:
        head = f.read(SNIFF_BYTES)
    if head[:4] == PARQUET_MAGIC:
        return Dialect("parquet")
    if b"\x00" in head:
        raise InputError(f"{name}: binary content, not a text CSV or a Parquet file")
    encoding = "utf-8-sig"
    try:
        text = head.decode(encoding)
    except UnicodeDecodeError as e:
        if e.start < len(head) - 4:  # not a character cut at the sniff boundary
            try:
                text, encoding = head.decode("cp1252"), "cp1252"  # Windows historians' default
            except UnicodeDecodeError:
                raise InputError(f"{name}: not a text CSV ({e.reason} at byte {e.start})") from None
        else:
            text = head[: e.start].decode(encoding)
    lines = [line for line in text.splitlines()[: SNIFF_ROWS + 1] if line.strip()]
    if len(head) == SNIFF_BYTES and len(lines) > 1:
        lines = lines[:-1]  # the last line may be cut
    if not lines:
        raise InputError(f"{name}: empty file, expected a header row with op and pv columns")
    header, data = lines[0], lines[1:]
    separator = _separator(header, data)
    if separator is None:
        raise InputError(
            f"{name}: the header {header.strip()[:60]!r} is one column: expected columns separated by "
            "',', ';', tab or '|'"
        )
    fields = next(csv.reader([header], delimiter=separator))
    if fields and all(_NUMBER.match(f) for f in fields if f.strip()):
        raise InputError(
            f"{name}: the first row {header.strip()[:60]!r} is numbers: expected a header row naming the columns "
            "(op, pv, and t, sp, mv if present)"
        )
    return Dialect("csv", separator, _decimal(separator, data), encoding)


def _separator(header: str, data: list[str]) -> str | None:
    best, best_score = None, (False, 1)
    for sep in SEPARATORS:
        n = len(next(csv.reader([header], delimiter=sep)))
        if n < 2:
            continue
        consistent = all(len(r) == n for r in csv.reader(data[:SNIFF_ROWS], delimiter=sep))
        score = (consistent, n)
        if score > best_score:
            best, best_score = sep, score
    return best


def _decimal(separator: str, data: list[str]) -> str:
    if separator == ",":
        return "."
    comma = point = 0
    for row in csv.reader(data[:SNIFF_ROWS], delimiter=separator):
        for field in row:
            comma += bool(_COMMA_DECIMAL.match(field))
            point += bool(_POINT_DECIMAL.match(field))
    return "," if comma and not point else "."
