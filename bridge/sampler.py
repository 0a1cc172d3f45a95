"""OPC UA value changes in, ``SampleBatch`` messages out: every loop sampled on one grid, sample and hold.

An OPC UA server reports a node only when its value changes, each change stamped with the
server's source timestamp.  The sampler keeps each node's recent changes and, once grid point
``t_k = k * ts_s`` (server time) is older than ``settle_s`` (changes arrive once per publishing
interval), emits every loop's value at ``t_k``: the node's last change at or before ``t_k``.
A loop's ``seq`` is ``k - k0`` from its first grid point, so a stretch the bridge could not read
(a bad status, a lost connection) is a gap in ``seq``, never a restart of the numbering.

Pure: no OPC UA, no Zenoh, no clock of its own; the edge passes server times in.
"""

from __future__ import annotations

import math
from collections import Counter, deque
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from stiction.schemas.loop_file import LoopNodes
from stiction.schemas.messages import MAX_BATCH_SAMPLES

REQUIRED = ("op", "pv")
MAX_CATCH_UP = MAX_BATCH_SAMPLES
"""Grid points emitted at most per loop and call: after a long stall only the last hour is sampled."""


@dataclass(frozen=True)
class Reading:
    """One value change of one loop's node, as the server reported it."""

    loop_id: str
    role: str
    value: object
    good: bool
    source_t_s: float | None
    arrival_t_s: float
    """The bridge's own clock when it arrived (for the clock offset, and when the server gave no time)."""


class Sampler:
    def __init__(self, loops: dict[str, LoopNodes], ts_s: float, settle_s: float | None = None):
        self.loops = loops
        self.ts_s = float(ts_s)
        # the clock offset already absorbs the least delay of a notification (the publishing cycle's
        # phase); settle_s covers the jitter around it
        self.settle_s = 0.5 * self.ts_s + 0.5 if settle_s is None else float(settle_s)
        self._changes: dict[tuple[str, str], list[tuple[float, float]]] = {}
        self._k_next: dict[str, int] = {}
        self._k0: dict[str, int] = {}
        self._offsets: deque[float] = deque(maxlen=1000)
        self.dropped: Counter[str] = Counter()
        self.missing: dict[str, str] = {}
        self.samples_published = 0
        self.publishing: set[str] = set()

    # in -------------------------------------------------------------------------------------------
    def offset_s(self) -> float:
        """Server clock minus the bridge's: the least-delayed of recent (source time - arrival)."""
        return max(self._offsets) if self._offsets else 0.0

    def server_time(self, bridge_t_s: float) -> float:
        return bridge_t_s + self.offset_s()

    def add(self, r: Reading) -> None:
        """One value change; a bad status or a value that is not a finite number is dropped and
        counted, and the node counts as unknown from then until its next good value."""
        if r.source_t_s is not None and r.good:
            self._offsets.append(r.source_t_s - r.arrival_t_s)
        t = r.source_t_s if r.source_t_s is not None else self.server_time(r.arrival_t_s)
        value = math.nan
        if not r.good:
            self.dropped["bad_status"] += 1
        else:
            try:
                value = float(r.value)
            except (TypeError, ValueError):
                self.dropped["not_a_number"] += 1
            else:
                if not math.isfinite(value):
                    self.dropped["not_finite"] += 1
                    value = math.nan
        changes = self._changes.setdefault((r.loop_id, r.role), [])
        if changes and t < changes[-1][0]:
            if not math.isnan(changes[-1][1]):
                self.dropped["out_of_order"] += 1
                return
            t = changes[-1][0]  # the first value after an unknown stretch: known from where the stretch ended
        changes.append((t, value))
        if r.good and self.missing.get(r.loop_id, "").startswith(f"{r.role} "):
            del self.missing[r.loop_id]

    def node_missing(self, loop_id: str, role: str, reason: str, t_s: float) -> None:
        """The server lacks a node of this loop (or it disappeared): said in the health, and the
        node is unknown from ``t_s`` on.  A loop without OP or PV stops; the others go on."""
        node = getattr(self.loops[loop_id], role)
        self.missing[loop_id] = f"{role} node {node}: {reason}"
        self._invalidate((loop_id, role), t_s)

    def disconnected(self, t_s: float) -> None:
        """The connection is lost: every node is unknown from ``t_s`` until its next value."""
        for loop_id, nodes in self.loops.items():
            for role in nodes.nodes():
                self._invalidate((loop_id, role), t_s)

    def _invalidate(self, key: tuple[str, str], t_s: float) -> None:
        changes = self._changes.setdefault(key, [])
        if not changes or not math.isnan(changes[-1][1]):
            changes.append((max(t_s, changes[-1][0]) if changes else t_s, math.nan))

    # out ------------------------------------------------------------------------------------------
    def due(self, server_t_s: float, loops: Iterable[str] | None = None) -> list[dict]:
        """Every loop's samples (``loops``: these loops' only) on the grid points that have settled by
        ``server_t_s`` and were not yet out, as ``SampleBatch`` dicts: one per run of grid points where OP and
        PV are known.  ``publishing`` is then the loops whose samples went out the last time they were asked."""
        k_end = math.floor((server_t_s - self.settle_s) / self.ts_s)
        out: list[dict] = []
        asked = list(self.loops) if loops is None else list(loops)
        self.publishing.difference_update(asked)
        for loop_id in asked:
            nodes = self.loops[loop_id]
            k = self._k_next.get(loop_id)
            if k is None:  # a loop starts at the first settled grid point where OP and PV are known
                start = np.array([k_end * self.ts_s])
                if not all(math.isfinite(self._at(loop_id, role, start)[0]) for role in REQUIRED):
                    self._prune(loop_id, start[0])
                    continue
                k = self._k0[loop_id] = k_end
            if k > k_end:
                continue
            k = max(k, k_end - MAX_CATCH_UP + 1)
            grid = np.arange(k, k_end + 1)
            t = grid * self.ts_s
            values = {role: self._at(loop_id, role, t) for role in nodes.nodes()}
            known = np.isfinite(values["op"]) & np.isfinite(values["pv"])
            for lo, hi in _runs(known):
                out.append(self._batch(loop_id, nodes, grid[lo], t[lo], {r: v[lo:hi] for r, v in values.items()}))
                self.samples_published += hi - lo
                self.publishing.add(loop_id)
            self._k_next[loop_id] = k_end + 1
            self._prune(loop_id, t[-1])
        return out

    def _at(self, loop_id: str, role: str, t: np.ndarray) -> np.ndarray:
        """The node's value at each time: its last change at or before it (NaN where unknown)."""
        changes = self._changes.get((loop_id, role))
        if not changes:
            return np.full(t.shape, np.nan)
        times = np.fromiter((c[0] for c in changes), float, len(changes))
        vals = np.fromiter((c[1] for c in changes), float, len(changes))
        i = np.searchsorted(times, t, side="right") - 1
        return np.where(i >= 0, vals[np.maximum(i, 0)], np.nan)

    def _prune(self, loop_id: str, t_s: float) -> None:
        """Forget changes older than the one in force at ``t_s``: they can no longer be sampled."""
        for role in self.loops[loop_id].nodes():
            changes = self._changes.get((loop_id, role))
            if changes and len(changes) > 1:
                i = sum(1 for c in changes if c[0] <= t_s)
                if i > 1:
                    del changes[: i - 1]

    def _batch(self, loop_id: str, nodes: LoopNodes, k: int, t0_s: float, values: dict[str, np.ndarray]) -> dict:
        batch = {
            "schema_version": 1,
            "loop_id": loop_id,
            "seq": int(k - self._k0[loop_id]),
            "t0_s": float(t0_s),
            "ts_s": self.ts_s,
            "op": values["op"].tolist(),
            "pv": values["pv"].tolist(),
            "process": nodes.process,
        }
        for role in ("sp", "mv", "mode"):  # an optional node goes out only where it is known throughout
            v = values.get(role)
            if v is not None and np.all(np.isfinite(v)):
                batch[role] = v.tolist()
        return batch


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` of each run of True, split so that none is longer than a batch may be."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(np.int8), 0]))
    out = []
    for lo, hi in zip(edges[::2], edges[1::2], strict=True):
        out += [(s, min(s + MAX_BATCH_SAMPLES, hi)) for s in range(lo, hi, MAX_BATCH_SAMPLES)]
    return out
