"""A loop's samples: the rolling window the agent keeps (a fixed-size ring, updated batch by
batch); the ``Window`` it hands to the pipeline is ``quantify.window``'s.  Light on purpose: the agent's core names
these types without importing the models, onnxruntime or the simulator."""

from __future__ import annotations

import numpy as np

from stiction.agent.coded_ring import CodedRing

DTYPE = np.float32
"""The setpoint and the valve position are held as float32 (7 significant digits, far finer than any transmitter);
OP and PV as three-byte codes (``agent.coded_ring``: within 2.4e-7 of the window's range), read back as float64 as
the pipeline computes, without float32's rounding on top (``agent.coded_ring`` says what that changed)."""


REPEAT_ATOL = 1e-6
"""Held and repeated samples within this (% of span) are the same: a publisher's history rounds its values to six
decimals (``bridge.history.DECIMALS``), and a live batch that arrives after the history holding it is a repeat,
not other samples.  Read as other samples, an inherited window lost its first live batch (981 samples of one loop
in two of nine ``stiction bench throughput`` runs, 2026-11-26, where a history reply met the burst that fills
the windows)."""


def _same(held: np.ndarray, new: np.ndarray, step: float) -> bool:
    """Equal but for the history's rounding, float32's (two units in the last place) and the codes' (a ``step``)."""
    held, new = held.astype(float), new.astype(float)
    return bool(np.all(np.abs(held - new) <= REPEAT_ATOL + step + 2.5e-7 * np.abs(new)))


SP_STEPS_KEPT = 32
"""A setpoint is kept as its steps (a few bytes each) while the window holds at most this many; one that moves more
often (a cascade's inner loop, whose setpoint is the outer controller's output) is kept as a ring of samples as
OP and PV are (4 kB at 1,000 samples).  Operators move setpoints a few times a shift: of 20,000 plant-like loops
(``stiction bench throughput --mix plant``) 37 % held a ring for one to three steps, about 30 MB of an agent's 500."""


def _steps_after(steps: list[tuple[int, float]], first: int, values: np.ndarray, start: int) -> list[tuple[int, float]]:
    """``steps`` with ``values`` (float32) written from sequence number ``first`` on, those it overwrites dropped
    (where it overwrites all, its first value stands for the samples before it, as a first setpoint does), and the
    steps before ``start`` (the window's first sample) dropped but the one in force there."""
    kept = [st for st in steps if st[0] < first] or [(first - len(values), float(values[0]))]
    last = kept[-1][1]
    moved = np.flatnonzero(values != np.r_[DTYPE(last), values[:-1]])
    kept += [(first + int(k), float(values[k])) for k in moved]
    _drop_slid_out(kept, start)
    return kept


def _drop_slid_out(steps: list[tuple[int, float]], start: int) -> None:
    """Drop, in place, the steps before ``start`` but the one in force there."""
    while len(steps) > 1 and steps[1][0] <= start:
        del steps[0]


def _expand(steps: list[tuple[int, float]], start: int, count: int) -> np.ndarray:
    """The setpoint of the ``count`` samples from sequence number ``start`` on, from its steps (the first in force
    at ``start``)."""
    at = np.clip(np.array([st[0] for st in steps]) - start, 0, count)
    return np.repeat(np.array([st[1] for st in steps], DTYPE), np.diff(np.r_[at, count]))


class RollingWindow:
    """The last ``size`` samples of OP and PV (and SP, the valve position MV, where the stream has them), numbered by
    ``seq``.

    ``update`` appends a batch that continues the stream; ``get`` returns the
    window oldest first, ``get_sp`` its setpoint and ``get_mv`` its valve position (None unless every sample held has
    one);
    ``snapshot`` is a plain dict for inspection.  A setpoint that never moves costs one number,
    not a ring.
    """

    __slots__ = ("size", "ts_s", "_op", "_pv", "count", "next_seq", "t_end_s", "_sp", "_sp_const", "_sp_steps",
                 "_sp_missing_until", "_mv", "_mv_missing_until")  # fmt: skip

    def __init__(self, size: int, ts_s: float):
        self.size = size
        self.ts_s = ts_s
        self._op = CodedRing(size)
        self._pv = CodedRing(size)
        self.count = 0  # samples held, at most size
        self.next_seq: int | None = None
        self.t_end_s: float | None = None
        self._sp: np.ndarray | None = None  # a ring, allocated once the setpoint moves often (``SP_STEPS_KEPT``)
        self._sp_const: float | None = None
        self._sp_steps: list[tuple[int, float]] | None = None  # (seq from which, setpoint), oldest first
        self._sp_missing_until = 0  # samples before this seq may lack a setpoint
        self._mv: np.ndarray | None = None  # allocated once a valve position arrives: most streams have none
        self._mv_missing_until = 0

    def update(self, seq: int, t0_s: float, op, pv, sp=None, mv=None) -> RollingWindow:
        n = len(op)
        self._update_sp(seq, n, sp)
        if mv is not None or self._mv is not None:
            self._update_mv(seq, n, mv)
        m = min(n, self.size)  # the last ``size`` samples, from their place in the ring on
        j = (seq + n - m) % self.size
        if n == 1 and isinstance(op, list) and isinstance(pv, list):  # the spec's one-sample stream: no run to wrap
            self._op.put(j, op)
            self._pv.put(j, pv)
        else:
            self._op.write_run(j, op[n - m :] if m < n else op)
            self._pv.write_run(j, pv[n - m :] if m < n else pv)
        self.count = min(self.size, self.count + n)
        if self.count == self.size and (seq + n) // self.size > seq // self.size:
            self._op.narrow()  # the ring turned over: an outlier slid out of the window gives back its resolution
            self._pv.narrow()
        self.next_seq = seq + n
        self.t_end_s = t0_s + (n - 1) * self.ts_s
        return self

    def _tail(self, seq: int, n: int, m: int) -> np.ndarray:
        """Ring positions of the last ``m`` of the ``n`` samples that start at ``seq``."""
        return (seq + n - m + np.arange(m)) % self.size

    def _held(self) -> np.ndarray:
        """Ring positions of the samples held, oldest first."""
        return self._tail(self.next_seq - self.count, self.count, self.count)

    def _update_sp(self, seq: int, n: int, sp) -> None:
        if sp is None:
            self._sp_missing_until = seq + n
            return
        steps, start = self._sp_steps, seq + n - self.size  # start: the window's first sample after this batch
        if (
            steps is not None
            and seq > steps[-1][0]
            and (float(DTYPE(sp[0])) == steps[-1][1] if n == 1 else all(float(DTYPE(v)) == steps[-1][1] for v in sp))
        ):
            _drop_slid_out(steps, start)  # the setpoint stands still (most messages)
            return
        if self._sp is None and steps is None:
            const = float(sp[0]) if self._sp_const is None else self._sp_const
            if (float(sp[0]) == const) if n == 1 else all(float(v) == const for v in sp):
                self._sp_const = const
                return
            self._sp_steps = [(seq - self.size, float(DTYPE(const)))]
        values = np.asarray(sp, float)[-self.size :].astype(DTYPE)
        first = seq + n - values.size
        if self._sp is None:
            self._sp_steps = _steps_after(self._sp_steps, first, values, start)
            if len(self._sp_steps) <= SP_STEPS_KEPT:
                return
            self._sp = np.empty(self.size, DTYPE)  # moves too often to keep as steps: a ring, as OP and PV
            self._sp[self._tail(start, self.size, self.size)] = _expand(self._sp_steps, start, self.size)
            self._sp_steps = None
            return
        self._sp[self._tail(seq, n, values.size)] = values

    def _update_mv(self, seq: int, n: int, mv) -> None:
        if mv is None:
            self._mv_missing_until = seq + n
            return
        if self._mv is None:
            self._mv = np.zeros(self.size, DTYPE)
            self._mv_missing_until = max(self._mv_missing_until, seq)  # the samples before had none
        mv = np.asarray(mv, float)[-self.size :]
        self._mv[self._tail(seq, n, mv.size)] = mv

    def get_mv(self) -> np.ndarray | None:
        """The valve position of the samples held, oldest first; None where any of them had none."""
        if self._mv is None or self.next_seq is None or self.next_seq - self.count < self._mv_missing_until:
            return None
        return self._mv[self._held()]

    def get_sp(self) -> np.ndarray | None:
        """The setpoint of the samples held, oldest first; None where any of them had none."""
        if self.next_seq is None or self.next_seq - self.count < self._sp_missing_until:
            return None
        if self._sp_steps is not None:
            return _expand(self._sp_steps, self.next_seq - self.count, self.count)
        if self._sp is None:
            return None if self._sp_const is None else np.full(self.count, self._sp_const, DTYPE)
        return self._sp[self._held()]

    def holds(self, seq: int, op, pv) -> bool:
        """These samples, at these sequence numbers, are already in the window (a repeated message)."""
        n = len(op)
        if self.next_seq is None or seq < self.next_seq - self.count or seq + n > self.next_seq:
            return False
        idx = (seq + np.arange(n)) % self.size
        op, pv = np.asarray(op, DTYPE), np.asarray(pv, DTYPE)  # compared as they were sent
        return _same(self._op.read(idx), op, self._op.step) and _same(self._pv.read(idx), pv, self._pv.step)

    def get(self) -> tuple[np.ndarray, np.ndarray]:
        """OP and PV of the samples held, oldest first."""
        if self.next_seq is None:
            return np.empty(0), np.empty(0)
        start = (self.next_seq - self.count) % self.size
        return self._op.read_run(start, self.count), self._pv.read_run(start, self.count)

    def snapshot(self) -> dict:
        op, pv = self.get()
        return {
            "size": self.size,
            "count": self.count,
            "next_seq": self.next_seq,
            "ts_s": self.ts_s,
            "t_end_s": self.t_end_s,
            "op": op.tolist(),
            "pv": pv.tolist(),
        }
