"""The windows the method reads: one loop's recent samples (``Window``), and a friction reading one
report hands on to the next (``Reading``).  Light on purpose: the agent's core names these types
without importing the models, onnxruntime or the simulator."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from stiction.schemas.errors import InputError

MIN_SAMPLES = 100
"""The thesis' window; the ACF then finds a period only for cycles up to about 50 samples."""


@dataclass(frozen=True)
class Reading:
    """The friction half of a stiction report: its fields and the warnings that came with them,
    read from the window that ended at ``t_end_s``."""

    fields: dict
    warnings: tuple[str, ...]
    t_end_s: float | None


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
