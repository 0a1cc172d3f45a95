"""A ring of one signal's samples held as three-byte codes on a grid (``base + code * step``), three quarters of
float32's memory: OP and PV of 20,000 loops of 1,000 samples are 120 MB instead of 160 MB of an agent's 500.

The grid follows the samples the ring holds, whatever their unit (the message schema bounds none).  ``step`` is a
power of two, at most 1/4,194,303 of the range of the samples it was fitted to (centred, half the codes in
reserve).  A sample is read back within a step of the coarsest grid it was held on: half a step where it was
written, half of each coarser one it was moved to.  The grids a sample is held on are fitted to the samples of its
window and of the window before, so its error is at most 2.4e-7 of their range: finer than float32 (6e-8 of the
value) wherever the range is more than a quarter of the value, and within the data checks' reading of a straight
line (``ident.checks.LINE_REL``, 1e-6 of the range) everywhere.  Two bytes a sample were tried and refused: at
1/16,383 of the range a gently curved OP reads as a historian's straight lines (35 of 560 simulated windows changed
their verdict to bad data).

- A sample past the grid's reach widens it (the step doubled until every code of the ring and the new samples fit,
  the base moved to their centre); the codes held are read and coded again on the coarser grid.
- A grid that the held samples no longer need (an outlier slid out of the window) narrows again, checked each time
  the ring turns over.  A finer power-of-two grid holds every point of the coarser: nothing moves.
- The base is a multiple of the step, so 0 is on every grid: a flow reading exactly zero reads back exactly zero,
  and a value repeated is read back repeated (one code).
"""

from __future__ import annotations

import math

import numpy as np

CODE_BYTES = 3
CODE_REACH = 2**23 - 1
"""The codes' reach either side of the base (24-bit signed)."""
CODES_FITTED = 2**22 - 1
"""A grid is fitted so that the samples it was fitted to take at most this many codes either side of its centre:
room to double before the next refit."""
FINEST_RELATIVE = 2.0**-40
"""The finest step relative to the grid's centre: a constant signal's first grid, far below float32's resolution
(2^-24), and keeps ``base + code * step`` exact in float64."""


def fitted_step(lo: float, hi: float) -> float:
    """The smallest power of two for which the samples in [lo, hi], about their centre, take at most
    ``CODES_FITTED`` codes either side; never finer than ``FINEST_RELATIVE`` of their magnitude."""
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    finest = FINEST_RELATIVE * max(abs(centre), abs(lo), abs(hi), 2.0**-100)
    return 2.0 ** math.ceil(math.log2(max(half / CODES_FITTED, finest)))


def _decode(raw: np.ndarray) -> np.ndarray:
    """int32 codes of ``raw`` [N, 3] little-endian 24-bit two's complement bytes: each put in the top three
    bytes of an int32, then shifted down with its sign."""
    wide = np.zeros((raw.shape[0], 4), np.uint8)
    wide[:, 1:] = raw
    return wide.view("<i4").ravel() >> 8


def _encode(codes: np.ndarray) -> bytes:
    """The 24-bit little-endian bytes of integer ``codes`` within ``CODE_REACH``."""
    return np.ascontiguousarray(codes.astype("<i4").view(np.uint8).reshape(-1, 4)[:, :CODE_BYTES]).tobytes()


class CodedRing:
    """``size`` samples as 24-bit codes; ``put`` writes one at a ring position, ``write`` a slice of positions,
    ``read`` any positions (an index array), as float32."""

    __slots__ = ("size", "buf", "base", "step")

    def __init__(self, size: int):
        self.size = size
        self.buf = bytearray(CODE_BYTES * size)
        self.base = 0.0
        self.step = 0.0  # no grid until the first write

    def codes(self, at=slice(None)) -> np.ndarray:
        """The codes at ring positions ``at``."""
        return _decode(np.frombuffer(self.buf, np.uint8).reshape(self.size, CODE_BYTES)[at])

    def read(self, at) -> np.ndarray:
        """The values at ring positions ``at`` (float32, as the window hands them on)."""
        return (self.base + self.codes(at) * self.step).astype(np.float32)

    def read_run(self, start: int, count: int) -> np.ndarray:
        """The ``count`` values from ring position ``start`` on, wrapping past the ring's end (a window oldest first:
        slices, no index array)."""
        first = min(count, self.size - start)
        codes = self.codes(slice(start, start + first))
        if first < count:
            codes = np.concatenate((codes, self.codes(slice(0, count - first))))
        return (self.base + codes * self.step).astype(np.float32)

    def put(self, at: int, values) -> None:
        """Write a few samples (a sequence of floats) from ring position ``at`` on, none past the ring's end: a
        stream of a few samples a message, coded in Python, no array set up (0.3 us a sample)."""
        if self.step:
            base, step = self.base, self.step
            codes = [round((v - base) / step) for v in values]
            if min(codes) >= -CODE_REACH and max(codes) <= CODE_REACH:
                self.buf[CODE_BYTES * at : CODE_BYTES * (at + len(codes))] = b"".join(
                    c.to_bytes(CODE_BYTES, "little", signed=True) for c in codes
                )
                return
        self.write(slice(at, at + len(values)), np.asarray(values, float))

    def write(self, at: slice, values: np.ndarray) -> None:
        """Write ``values`` (float64) at the ring positions of the slice ``at``.  A new grid reaches every position of
        the ring: the samples held, those about to be overwritten, and positions never written (code 0, the grid's
        base), so it is never narrower than what is read from it."""
        if self.step == 0.0:  # the first samples: a grid about them
            lo, hi = float(values.min()), float(values.max())
            self.step = fitted_step(lo, hi)
            self.base = round(0.5 * (lo + hi) / self.step) * self.step
        c = (values - self.base) / self.step
        if c.max() > CODE_REACH or c.min() < -CODE_REACH:
            held = self.codes()
            lo = min(float(values.min()), self.base + int(held.min()) * self.step)
            hi = max(float(values.max()), self.base + int(held.max()) * self.step)
            self._regrid(held, max(fitted_step(lo, hi), self.step), 0.5 * (lo + hi))
            c = (values - self.base) / self.step
        start, stop, _ = at.indices(self.size)
        self.buf[CODE_BYTES * start : CODE_BYTES * stop] = _encode(np.rint(c))

    def narrow(self) -> None:
        """Refit to the samples held where a finer grid reaches them all (call once the ring has turned over:
        every position then holds a sample of the window)."""
        if self.step == 0.0:
            return
        held = self.codes()
        lo, hi = self.base + int(held.min()) * self.step, self.base + int(held.max()) * self.step
        step = fitted_step(lo, hi)
        if step < self.step:
            self._regrid(held, step, 0.5 * (lo + hi))

    def _regrid(self, held: np.ndarray, step: float, centre: float) -> None:
        """Code the ring's ``held`` codes again on the grid of ``step`` whose base is the multiple of it nearest
        ``centre``."""
        values = self.base + held * self.step
        self.base, self.step = round(centre / step) * step, step
        self.buf[:] = _encode(np.rint((values - self.base) / step))
