"""Samples onto Zenoh: the one place this project's publishers (``stiction sim``, ``replay``, the OPC UA
bridge, the throughput bench) put ``SampleBatch`` messages and answer for their recent history.

By default each loop goes on its shard's key ``{prefix}/loop/{id}/samples/{shard}`` (agents then
receive only their own shards' samples) and ``get`` on ``{prefix}/loop/*/samples/...?last=N`` is
answered with every matching loop's last N samples (``bridge.history``); ``sharded=False`` puts
on the spec's key ``{prefix}/loop/{id}/samples``, which every agent receives.  Congestion control
is BLOCK: a slow subscriber slows the publisher down instead of losing samples.
"""

from __future__ import annotations

import json
import logging

import numpy as np

from stiction.bridge.history import SampleHistory
from stiction.schemas import keys

log = logging.getLogger(__name__)

DEFAULT_LAST = 1000
STAGGER_STEP_S = 0.05
"""A publisher sends its loops' batches in groups this far apart over each message interval."""


def stagger_groups(n_loops: int, interval_s: float, step_s: float = STAGGER_STEP_S) -> list[np.ndarray]:
    """The loops' indices in the groups a publisher sends one after another, ``step_s`` apart, over
    each interval of ``interval_s`` between a loop's messages: loop ``j`` in group ``j mod groups``.

    Sent in the same instant, every loop's batch of several seconds makes the loops that fall due
    in it (a twelfth of them, for 5-s batches and a report every 60 samples) due at once, and their
    reports wait on each other; a bridge spreads its loops over the interval, and so do these."""
    groups = int(max(1, min(n_loops, round(interval_s / step_s))))
    return [np.arange(k, n_loops, groups) for k in range(groups)]


def encode(batch: dict) -> bytes:
    """A ``SampleBatch`` as JSON, built directly (pydantic per message is too slow for 10,000 loops)."""
    body = {"schema_version": 1} | {k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in batch.items()}
    return json.dumps(body).encode()


class SamplePublisher:
    def __init__(self, session, prefix: str, sharded: bool = True, keep_samples: int = DEFAULT_LAST):
        import zenoh

        self._zenoh = zenoh
        self.session = session
        self.prefix = keys.check_prefix(prefix)
        self.sharded = sharded
        self.history = SampleHistory(keep_samples) if keep_samples > 0 else None
        self.queries = 0
        self._publishers: dict[str, object] = {}
        self._queryable = (
            session.declare_queryable(keys.samples_any(prefix), self._on_query) if self.history is not None else None
        )

    def key(self, loop_id: str) -> str:
        return keys.sharded_samples(self.prefix, loop_id) if self.sharded else keys.samples(self.prefix, loop_id)

    def _publisher(self, loop_id: str):
        pub = self._publishers.get(loop_id)
        if pub is None:
            pub = self._publishers[loop_id] = self.session.declare_publisher(
                self.key(loop_id),
                encoding=self._zenoh.Encoding.APPLICATION_JSON,
                congestion_control=self._zenoh.CongestionControl.BLOCK,
            )
        return pub

    def put(self, batch: dict) -> None:
        """One batch of one loop: ``SampleBatch`` fields (``schema_version`` may be left out); arrays or lists."""
        self._publisher(batch["loop_id"]).put(encode(batch))
        if self.history is not None:
            self.history.record(batch)

    def wait_for_subscribers(self, loop_ids, timeout_s: float, stop=None) -> int:
        """How many of ``loop_ids`` have a subscriber (Zenoh's matching status) once every one has, or
        ``timeout_s`` has passed, or ``stop`` (a ``threading.Event``) is set.

        A finite stream (``stiction replay``) asks this before its first batch: started beside an agent
        that has just connected, it sent its first batches before the agent's subscription reached it,
        and they were lost (a 1,000-sample export into an agent whose first window is 1,000 then reported
        nothing; 1 in 3 to 7 runs of ``tests/integration/test_agent_fits.py``)."""
        import threading
        import time

        tick = stop or threading.Event()
        asked = [self._publisher(i) for i in dict.fromkeys(loop_ids)]
        waiting, deadline = asked, time.monotonic() + timeout_s
        while True:
            waiting = [p for p in waiting if not p.matching_status.matching]
            if not waiting or time.monotonic() >= deadline or tick.is_set():
                return len(asked) - len(waiting)
            tick.wait(0.02)

    def _on_query(self, query) -> None:
        try:
            last = int(query.parameters.get("last", str(DEFAULT_LAST)))
        except ValueError:
            query.reply_err(b"last: a whole number of samples")
            return
        self.queries += 1
        for key, payload in self.history.answer(self.prefix, str(query.key_expr), last, self.sharded):
            query.reply(key, payload, encoding=self._zenoh.Encoding.APPLICATION_JSON)

    def close(self) -> None:
        for pub in self._publishers.values():
            pub.undeclare()
        self._publishers.clear()
        if self._queryable is not None:
            self._queryable.undeclare()
            self._queryable = None
