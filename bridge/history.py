"""A publisher's memory of each loop's recent samples, to answer an agent that inherits a shard.

Agents subscribe only to the shards they own (``schemas.keys``): when an agent dies or joins,
the shards' new owner asks the publishers for the loops' recent samples (``get`` on
``{prefix}/loop/*/samples/{shard}?last=N``) and rebuilds their windows from the answer, so that
no agent has to hold a copy of every window in case its neighbour dies.  Pure: the Zenoh edge is
``bridge.publish``.
"""

from __future__ import annotations

import json
import threading
from dataclasses import dataclass, field

import numpy as np

from stiction.schemas import keys
from stiction.schemas.messages import MAX_BATCH_SAMPLES, SAMPLE_COLUMNS

DECIMALS = 6
"""Decimals of the history's values (% of span): finer than the float32 the agent holds them in
(about 4e-6 at 50 %), and the answer is built in two thirds of the time, in half the bytes."""


@dataclass
class _Ring:
    size: int
    ts_s: float
    process: str | None
    next_seq: int = 0
    count: int = 0
    t_end_s: float = 0.0
    columns: dict[str, np.ndarray] = field(default_factory=dict)

    def add(self, batch: dict) -> None:
        n = len(batch["op"])
        if self.count and (batch["seq"] != self.next_seq or batch["ts_s"] != self.ts_s):
            self.count, self.columns = 0, {}  # a gap or a new sample time: the history restarts
        present = [c for c in SAMPLE_COLUMNS if batch.get(c) is not None]
        if self.count and set(present) != set(self.columns):
            self.count, self.columns = 0, {}  # a column came or went: keep only what every sample has
        m = min(n, self.size)
        idx = (batch["seq"] + n - m + np.arange(m)) % self.size
        for c in present:
            ring = self.columns.get(c)
            if ring is None:
                ring = self.columns[c] = np.zeros(self.size)
            ring[idx] = np.asarray(batch[c], float)[n - m :]
        self.ts_s, self.process = batch["ts_s"], batch.get("process")
        self.next_seq = batch["seq"] + n
        self.count = min(self.size, self.count + n)
        self.t_end_s = batch["t0_s"] + (n - 1) * batch["ts_s"]

    def last(self, loop_id: str, n: int) -> bytes | None:
        """The last ``n`` samples as a ``SampleBatch`` (JSON), or None if none are held."""
        m = min(n, self.count, MAX_BATCH_SAMPLES)
        if m <= 0:
            return None
        seq = self.next_seq - m
        idx = (seq + np.arange(m)) % self.size
        body = {
            "schema_version": 1,
            "loop_id": loop_id,
            "seq": seq,
            "t0_s": self.t_end_s - (m - 1) * self.ts_s,
            "ts_s": self.ts_s,
            **{c: np.round(ring[idx], DECIMALS).tolist() for c, ring in self.columns.items()},
            "process": self.process,
        }
        return json.dumps(body).encode()


class SampleHistory:
    """The last ``keep_samples`` samples of every loop put through it, by loop and shard."""

    def __init__(self, keep_samples: int = 1000):
        if keep_samples < 1:
            raise ValueError("keep_samples must be positive")
        self.keep_samples = keep_samples
        self._rings: dict[str, _Ring] = {}
        self._by_shard: dict[int, list[str]] = {}
        self._lock = threading.Lock()  # puts come from the publishing thread, queries from Zenoh's

    def record(self, batch: dict) -> None:
        """A batch as published (``SampleBatch`` fields; lists or arrays)."""
        loop_id = batch["loop_id"]
        with self._lock:
            ring = self._rings.get(loop_id)
            if ring is None:
                ring = self._rings[loop_id] = _Ring(self.keep_samples, batch["ts_s"], batch.get("process"))
                self._by_shard.setdefault(keys.shard_of(loop_id), []).append(loop_id)
            ring.add(batch)

    def answer(self, prefix: str, query_key: str, last: int, sharded: bool) -> list[tuple[str, bytes]]:
        """(key, payload) of every loop the query's key expression names, with its last ``last`` samples.

        Understood: ``{prefix}/loop/{id or *}/samples``, ``.../samples/{shard, * or **}``; a loop's
        reply goes on the key it is published on, so a query of shard keys is not answered for
        loops published on the spec's key, and the reverse."""
        head = f"{prefix}/loop/"
        if not query_key.startswith(head):
            return []
        parts = query_key[len(head) :].split("/")
        if len(parts) < 2 or parts[1] not in ("samples", "*", "**") or len(parts) > 3:
            return []
        shard_part = parts[2] if len(parts) == 3 else None
        if sharded and shard_part is None and parts[1] == "samples":
            return []
        if not sharded and shard_part not in (None, "**"):
            return []
        with self._lock:
            if parts[0] in ("*", "**"):
                if sharded and shard_part is not None and shard_part.isdigit():
                    ids = list(self._by_shard.get(int(shard_part), []))
                else:
                    ids = list(self._rings)
            else:
                ids = [parts[0]] if parts[0] in self._rings else []
                if sharded and ids and shard_part is not None and shard_part.isdigit():
                    ids = [i for i in ids if keys.shard_of(i) == int(shard_part)]
            out = []
            for loop_id in ids:
                payload = self._rings[loop_id].last(loop_id, last)
                if payload is not None:
                    key = keys.sharded_samples(prefix, loop_id) if sharded else keys.samples(prefix, loop_id)
                    out.append((key, payload))
        return out
