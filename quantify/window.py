"""The windows the method reads: one loop's recent samples (``Window``), and a friction reading one
report hands on to the next (``Reading``).  Light on purpose: the agent's core names these types
without importing the models, onnxruntime or the simulator."""

from __future__ import annotations

import math
from array import array
from dataclasses import dataclass

import numpy as np

from stiction.schemas.errors import InputError

MIN_SAMPLES = 100
"""The thesis' window; the ACF then finds a period only for cycles up to about 50 samples."""


_LAYOUTS: dict[tuple, tuple] = {}
"""Every reading's layout (its fields' names and kinds), held once: a few differ, thousands of readings share them."""


class Reading:
    """The friction half of a stiction report: its fields and the warnings that came with them,
    read from the window that ended at ``t_end_s``.

    Held packed, since an agent keeps one for every loop it calls sticky: the numbers as one ``bytes`` of float64,
    the rest (names, kinds, words) in a layout shared by every reading of the same shape.  As a dict of the
    report's values and blocks a reading was 2 kB, 41 MB of an agent's 20,000 sticky loops; packed, 0.3 kB.
    ``fields`` unpacks it: the numbers as floats, a block (an ``Estimate``) as the dict of its fields, which the
    report validates back (nan, as a block's number, reads as None: a report never holds nan)."""

    __slots__ = ("_layout", "_numbers", "_words", "warnings", "t_end_s")

    def __init__(self, fields: dict, warnings: tuple[str, ...] = (), t_end_s: float | None = None):
        layout, numbers, words = [], [], []
        for key, value in fields.items():
            block = value.model_dump() if hasattr(value, "model_dump") else None
            if isinstance(value, float):
                layout.append((key, "f"))
                numbers.append(value)
            elif block is not None and all(v is None or isinstance(v, float) for v in block.values()):
                layout.append((key, "block", tuple(block)))
                numbers += [math.nan if v is None else v for v in block.values()]
            else:
                layout.append((key, "word"))
                words.append(value)
        shape = tuple(layout)
        self._layout = _LAYOUTS.setdefault(shape, shape)
        self._numbers = array("d", numbers).tobytes()
        self._words = tuple(words)
        self.warnings = tuple(warnings)
        self.t_end_s = t_end_s

    @property
    def fields(self) -> dict:
        numbers, words = iter(array("d", self._numbers)), iter(self._words)
        out = {}
        for key, kind, *names in self._layout:
            if kind == "f":
                out[key] = next(numbers)
            elif kind == "block":
                out[key] = {name: None if math.isnan(v := next(numbers)) else v for name in names[0]}
            else:
                out[key] = next(words)
        return out

    def __eq__(self, other) -> bool:
        if not isinstance(other, Reading):
            return NotImplemented
        return (self._layout, self._numbers, self._words, self.warnings, self.t_end_s) == (
            other._layout, other._numbers, other._words, other.warnings, other.t_end_s
        )  # fmt: skip

    __hash__ = None

    def __reduce__(self):
        """Pickled (a worker's reading sent back to the agent) with its layout shared again on arrival."""
        return _unpickled, (self._layout, self._numbers, self._words, self.warnings, self.t_end_s)

    def __repr__(self) -> str:
        return f"Reading({self.fields!r}, {self.warnings!r}, {self.t_end_s!r})"


@dataclass(frozen=True)
class Window:
    """One loop's recent samples: OP and PV in percent of span, evenly spaced by ``ts_s``."""

    loop_id: str
    op: np.ndarray
    pv: np.ndarray
    ts_s: float = 1.0
    t_end_s: float | None = None
    process: str | None = None
    """``"level"`` for the canonical level loop (its physical reading applies); None when unknown."""
    sp: np.ndarray | None = None
    """Setpoint, where recorded: the detector reads the control error, and setpoint moves."""
    full_samples: int | None = None
    """The agent's full window; a shorter window is a new loop's partial first window."""
    interpolated: int = 0
    """Samples filled in across short gaps of the stream."""
    mv: np.ndarray | None = None
    """The valve's position, where the stream records it (a positioner's travel feedback): the agent checks the valve
    against it in the background (``quantify.stem``); the pipeline does not read it."""
    carry: Reading | None = None
    """A recent window's friction reading of this loop: where this window is still called sticky, its
    report carries that reading instead of running the INLPCA and the models again (the agent's
    cadence, ``--estimate-every``); where it is not, the reading is dropped."""
    defer_reading: bool = False
    """Without a carry: a window called sticky reports its verdict and no friction numbers this time
    (the agent rations readings while it catches up); a warning says so."""

    @property
    def partial(self) -> bool:
        """A new loop's first window, shorter than the agent's full one."""
        return self.full_samples is not None and len(self.op) < self.full_samples

    def validate(self) -> None:
        op, pv = np.asarray(self.op), np.asarray(self.pv)
        if op.ndim != 1 or op.shape != pv.shape:
            raise InputError(f"loop {self.loop_id}: op and pv must be 1-D of equal length, got {op.shape}, {pv.shape}")
        if op.size < MIN_SAMPLES:
            raise InputError(f"loop {self.loop_id}: {op.size} samples, need at least {MIN_SAMPLES}")
        for name, x in (("op", op), ("pv", pv)):
            bad = np.flatnonzero(~np.isfinite(x))
            if bad.size:
                raise InputError(f"loop {self.loop_id}: {name} is not finite at sample {bad[0]} ({bad.size} samples)")
        if not (math.isfinite(self.ts_s) and self.ts_s > 0):
            raise InputError(f"loop {self.loop_id}: sample time must be > 0 s, got {self.ts_s}")
        if self.process not in (None, "level"):
            raise InputError(f"loop {self.loop_id}: process {self.process!r} unknown, expected 'level' or none")


def _unpickled(layout: tuple, numbers: bytes, words: tuple, warnings: tuple, t_end_s: float | None) -> Reading:
    reading = Reading.__new__(Reading)
    reading._layout = _LAYOUTS.setdefault(layout, layout)
    reading._numbers, reading._words, reading.warnings, reading.t_end_s = numbers, words, warnings, t_end_s
    return reading
