"""The agent's pure core: messages in, windows due for a report out; no Zenoh, no clock of its own.

Ownership: each loop's shard (``keys.shard_of``) belongs to one live agent, by rendezvous
hashing with a cap on the shards an agent takes (``assign``: every agent gets its even share).
A loop published on the spec's key ``{prefix}/loop/{id}/samples`` reaches every agent, and the agent
that would inherit its shard keeps its window too, so that it reports at
once when the owner's liveliness token disappears.  A loop published on its shard's key reaches
only the agents subscribed to that shard, its owner: an agent that inherits the shard rebuilds
the loop's window from the publisher's history (``ingest(..., history=True)``) and keeps the
dead owner's report schedule from the reports it has seen.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import math
from collections import Counter
from dataclasses import dataclass

import numpy as np
from pydantic import ValidationError

from stiction.agent.ownership import assign, rank
from stiction.agent.window import RollingWindow
from stiction.quantify.window import Reading, Window
from stiction.schemas import keys
from stiction.schemas.messages import SAMPLE_COLUMNS, SampleBatch

_decode = SampleBatch.__pydantic_validator__.validate_json
"""``SampleBatch.model_validate_json`` without its Python wrapper (the same validator: called for every message)."""

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class CoreSettings:
    prefix: str = keys.DEFAULT_PREFIX
    window_samples: int = 1000
    report_every_samples: int = 60
    max_loops: int = 20000
    max_payload_bytes: int = 512 * 1024
    replicas: int = 2
    first_report_samples: int = 200
    """A new loop's first report comes once it holds this many samples (a partial window, flagged);
    the window then grows to ``window_samples``."""
    stagger: bool = True
    """Spread new loops' first reports over ``report_every_samples`` (by a hash of the loop id), so
    that thousands of loops started together do not fall due in the same second ever after."""
    max_fill_samples: int | None = None
    """Gaps of the stream up to this many samples are filled by linear interpolation (counted, and
    said in the report); longer gaps restart the window.  None: a tenth of the window."""

    estimate_every: int = 5
    """A loop that stays sticky has its friction read afresh every this many reports (five minutes
    at 1 Hz); the reports between carry the last reading, with the end of the window it came from
    (``estimate_t_end_s``).  Its verdict and data checks are read from every window.  1: every report."""

    reading_lag_s: float = 0.15
    """While the oldest due window has waited longer than this for its report, the agent is behind:
    fresh friction readings are rationed (``due_loops``).  An agent that keeps up reads every one."""

    @property
    def fill_limit(self) -> int:
        return self.window_samples // 10 if self.max_fill_samples is None else self.max_fill_samples


@dataclass(slots=True)
class _Loop:
    window: RollingWindow
    process: str | None
    new_since_report: int = 0
    arrived_at: float = 0.0
    first_at: int = 0
    """Samples held before this loop's first report."""
    filled: list[tuple[int, int]] | None = None
    """(first seq, samples) of each interpolated gap still in the window."""
    reading: Reading | None = None
    """The last friction reading of this loop while it is called sticky, and the reports that used it."""
    reading_reports: int = 0
    kept_until_s: float = -math.inf
    """A reading adopted from a background fit (``adopt``) is carried, not read afresh, until then."""
    verdict: str | None = None
    """The verdict of this loop's last report (None before the first)."""
    reported_to_s: float = -math.inf
    """End of the latest window of this loop reported by any agent (seen on the key space)."""
    queued: bool = False
    """In the core's queue of due loops: ``due_loops`` looks at these only, not at every loop held."""
    sharded: bool = False
    """Its samples come on its shard's key: only the shard's owner holds it."""

    def interpolated(self) -> int:
        """Interpolated samples inside the window now (older gaps are forgotten)."""
        w = self.window
        if not self.filled or w.next_seq is None:
            return 0
        start = w.next_seq - w.count
        self.filled = [(s, n) for s, n in self.filled if s + n > start]
        return sum(min(s + n, w.next_seq) - max(s, start) for s, n in self.filled)


@dataclass(frozen=True)
class Due:
    """A loop due for a report, without its window: the agent builds windows a batch at a time
    (``AgentCore.window``), not all at once.  Built together, the copies of thousands of due windows
    (12 kB each) were freed after the reports allocated in between, and the heap kept their holes:
    with 10,000 loops due in one pass the agent's heap held 168 MB free of 302, 23 MB once windows
    were built a batch at a time (RSS 526 -> 377 MB; a script outside the tree, the service's report
    loop on a stub session).  A pass has that many due only when the agent ingests a backlog whole
    (``agent.service.BACKLOG_MESSAGES``); keeping up, it ingests a thousand messages a pass and the
    throughput bench's peak RSS did not move (docs/scaling.md)."""

    loop_id: str
    arrived_s: float
    """When the last sample of its window arrived (the report's latency counts from it)."""
    interpolated: int = 0
    carry: Reading | None = None
    defer_reading: bool = False


def _tail(batch: SampleBatch, head: int) -> SampleBatch:
    """``batch`` without its first ``head`` samples."""
    cut = {c: v[head:] for c in SAMPLE_COLUMNS if (v := getattr(batch, c)) is not None}
    return batch.model_copy(update={"seq": batch.seq + head, "t0_s": batch.t0_s + head * batch.ts_s, **cut})


class AgentCore:
    def __init__(self, agent_id: str, settings: CoreSettings = CoreSettings()):
        self.agent_id = keys.check_id(agent_id, "agent id")
        self.settings = settings
        self.loops: dict[str, _Loop] = {}
        self.rejected: Counter[str] = Counter()
        self.samples = 0
        self.reports = 0
        self.gaps_filled = 0
        self.samples_filled = 0
        self.readings_deferred = 0
        self._queue: list[str] = []  # loops due for a report (owned or not), oldest first
        self.latencies: list[float] = []
        self.agents: tuple[str, ...] = (self.agent_id,)
        self._roles: dict[int, int] = {}  # shard -> this agent's rank among live agents, cached per membership
        self.reported_to_s: dict[str, float] = {}
        """End of the latest window of every loop reported by any agent (seen on the key space): an agent
        that inherits a shard keeps its loops' report schedule."""
        self.history_merged = 0
        self._keys: dict[str, tuple[str, bool, int]] = {}
        """Samples keys seen and valid: (loop id, sharded, shard), so that a key is parsed and its shard hashed
        once, not at every message (``_parse_key``)."""

    # ownership -------------------------------------------------------------------------------
    def set_agents(self, alive: set[str]) -> bool:
        """The live agents; True if they changed.  Sharded loops of shards this agent no longer owns
        are dropped (their samples stop coming; their new owner holds them)."""
        agents = tuple(sorted(alive | {self.agent_id}))
        if agents == self.agents:
            return False
        log.info("agents alive: %s", ", ".join(agents))
        self.agents = agents
        self._roles.clear()
        for loop_id in [lid for lid, st in self.loops.items() if st.sharded and not self.owns(lid)]:
            del self.loops[loop_id]
        return True

    def shard_role(self, shard: int) -> int:
        """0 if this agent owns the shard, 1 if it would own it should its owner die, else 2."""
        if not self._roles:
            owners = assign(self.agents)
            heirs = {a: assign(tuple(b for b in self.agents if b != a)) for a in self.agents if len(self.agents) > 1}
            for k, a in enumerate(owners):
                self._roles[k] = 0 if a == self.agent_id else 1 if a in heirs and heirs[a][k] == self.agent_id else 2
        return self._roles[shard]

    def owned_shards(self) -> set[int]:
        return {k for k in range(keys.SHARDS) if self.shard_role(k) == 0}

    def role(self, loop_id: str) -> int:
        """0 if this agent owns the loop (its shard), 1 if it ranks second, ... among the live agents."""
        return self.shard_role(keys.shard_of(loop_id))

    def owns(self, loop_id: str) -> bool:
        return self.role(loop_id) == 0

    # ingest ----------------------------------------------------------------------------------
    def reject(self, reason: str, detail: str = "") -> None:
        self.rejected[reason] += 1
        log.debug("rejected (%s) %s", reason, detail)

    def ingest(self, key: str, payload: bytes, encoding: str, now_s: float, history: bool = False) -> None:
        """One message from ``{prefix}/loop/{id}/samples`` (or its shard's key); anything wrong is
        counted, never raised.  ``history``: a publisher's reply with a loop's recent samples, which
        go in front of what the window holds."""
        parsed = self._keys.get(key) or self._parse_key(key)
        if parsed is None:
            return None
        loop_id, sharded, shard = parsed
        if self.shard_role(shard) >= (1 if sharded else self.settings.replicas):
            return None  # another agent's loop, and not one this agent would inherit
        if len(payload) > self.settings.max_payload_bytes:
            return self.reject("oversized_payload", f"{key}: {len(payload)} bytes")
        if not encoding.startswith("application/json"):
            return self.reject("wrong_encoding", f"{key}: {encoding}")
        try:
            batch = _decode(payload)
        except ValidationError as e:
            return self.reject(_reason(e), f"{key}: {e.errors()[0]['msg']}")
        if batch.loop_id != loop_id:
            return self.reject("loop_id_mismatch", f"{key} carries {batch.loop_id}")
        state = self.loops.get(loop_id)
        if state is None:
            if len(self.loops) >= self.settings.max_loops:
                return self.reject("too_many_loops", loop_id)
            state = self.loops[loop_id] = _Loop(RollingWindow(self.settings.window_samples, batch.ts_s), batch.process)
            state.first_at = self._first_at(loop_id)
            state.reported_to_s = self.reported_to_s.get(loop_id, -math.inf)
        state.sharded = sharded
        if history:
            return self._merge_history(loop_id, state, batch, now_s)
        w = state.window
        if w.next_seq is not None:
            if batch.ts_s != w.ts_s:
                self.reject("sample_time_changed", loop_id)
                w = state.window = RollingWindow(self.settings.window_samples, batch.ts_s)
                state.new_since_report, state.reading = 0, None
            elif batch.seq < w.next_seq:
                head = w.next_seq - batch.seq
                if head < len(batch.op) and w.holds(batch.seq, batch.op[:head], batch.pv[:head]):
                    batch = _tail(batch, head)  # its head repeats what a publisher's history brought: the rest is new
                else:
                    reason = "duplicate" if w.holds(batch.seq, batch.op, batch.pv) else "out_of_order"
                    return self.reject(reason, f"{loop_id} seq {batch.seq} < {w.next_seq}")
            elif batch.seq > w.next_seq and batch.seq - w.next_seq <= self.settings.fill_limit:
                self._fill(state, batch)
            elif batch.seq > w.next_seq:
                self.reject("gap", f"{loop_id} seq {batch.seq} > {w.next_seq}: window restarted")
                w = state.window = RollingWindow(self.settings.window_samples, batch.ts_s)
                state.new_since_report, state.filled, state.reading = 0, None, None
        w.update(batch.seq, batch.t0_s, batch.op, batch.pv, batch.sp, batch.mv)
        state.process = batch.process
        state.new_since_report += len(batch.op)
        state.arrived_at = now_s
        self.samples += len(batch.op)
        if not state.queued and self._is_due(state):
            state.queued = True
            self._queue.append(loop_id)
        return None

    def _parse_key(self, key: str) -> tuple[str, bool, int] | None:
        """A samples key's loop id, whether it is a shard's key, and the loop's shard; None (rejected) where
        the key is not a samples key or names the wrong shard.  Valid keys are remembered, as many as
        twice the loops an agent may hold."""
        loop_id = keys.loop_id_of(self.settings.prefix, key)
        if loop_id is None:
            return self.reject("bad_key", key)
        sharded, shard = keys.is_sharded(key), keys.shard_of(loop_id)
        if sharded and key.rsplit("/", 1)[1] != str(shard):
            return self.reject("wrong_shard", key)
        if len(self._keys) < 2 * self.settings.max_loops:
            self._keys[key] = (loop_id, sharded, shard)
        return loop_id, sharded, shard

    def _merge_history(self, loop_id: str, state: _Loop, batch: SampleBatch, now_s: float) -> None:
        """A loop's recent samples from its publisher (an inherited shard): the window becomes the
        history, then what had already come live; its schedule resumes from the last report seen."""
        w = state.window
        end = batch.seq + len(batch.op)
        if w.next_seq is not None and (batch.ts_s != w.ts_s or end < w.next_seq - w.count):
            return self.reject("history_gap", f"{loop_id}: history ends at {end}, window starts later")
        if w.next_seq is not None and batch.seq >= w.next_seq - w.count:
            return None  # nothing older than what the window holds
        merged = RollingWindow(self.settings.window_samples, batch.ts_s)
        start = end if w.next_seq is None else w.next_seq - w.count
        n = start - batch.seq
        sp, mv = (None if x is None else x[:n] for x in (batch.sp, batch.mv))
        merged.update(batch.seq, batch.t0_s, batch.op[:n], batch.pv[:n], sp, mv)
        if w.next_seq is not None:
            op, pv = w.get()
            merged.update(start, w.t_end_s - (w.count - 1) * w.ts_s, op, pv, w.get_sp(), w.get_mv())
        state.window = merged
        state.process = state.process or batch.process
        after = (merged.t_end_s - state.reported_to_s) / merged.ts_s
        state.new_since_report = int(round(min(after, merged.count)))
        state.arrived_at = now_s
        self.history_merged += 1
        self.samples += n  # taken in from the history: a live repeat of them is refused, not counted twice
        if not state.queued and self._is_due(state):
            state.queued = True
            self._queue.append(loop_id)
        return None

    def _is_due(self, state: _Loop) -> bool:
        return state.window.count >= state.first_at and state.new_since_report >= self.settings.report_every_samples

    def _fill(self, state: _Loop, batch: SampleBatch) -> None:
        """A short gap: the missing samples drawn on the straight line from the last held sample to
        the batch's first, so that the window goes on instead of restarting."""
        w = state.window
        start, missing = w.next_seq, batch.seq - w.next_seq
        op, pv = w.get()
        sp, mv = w.get_sp(), w.get_mv()
        frac = np.arange(1, missing + 1) / (missing + 1)
        w.update(
            start,
            w.t_end_s + w.ts_s,
            op[-1] + frac * (batch.op[0] - op[-1]),
            pv[-1] + frac * (batch.pv[0] - pv[-1]),
            None if sp is None or batch.sp is None else sp[-1] + frac * (batch.sp[0] - sp[-1]),
            None if mv is None or batch.mv is None else mv[-1] + frac * (batch.mv[0] - mv[-1]),
        )
        state.filled = (state.filled or []) + [(start, missing)]
        state.new_since_report += missing
        self.gaps_filled += 1
        self.samples_filled += missing
        log.debug("%s: %d missing samples from seq %d interpolated", batch.loop_id, missing, start)

    def _first_at(self, loop_id: str) -> int:
        first = min(self.settings.first_report_samples, self.settings.window_samples)
        if self.settings.stagger:
            first += rank("first report", loop_id) % self.settings.report_every_samples
        return min(first, self.settings.window_samples)

    # reports ---------------------------------------------------------------------------------
    def due_loops(self, now_s: float | None = None) -> list[Due]:
        """Owned loops with enough samples (a new loop's first, partial window; then the full window)
        and enough new samples since their last report, oldest first; ``window`` builds each one's window.

        Friction readings (the dear part of a report) are rationed: a loop still called sticky
        carries its reading for ``estimate_every`` reports (a fit's, ``adopt``, until its ``keep_until_s``).
        Due loops that want a fresh one (sticky, or not reported yet) all get it while the agent keeps up;
        once the oldest due window has waited more than ``reading_lag_s`` at ``now_s``, only a
        1/``estimate_every`` share does, loops never read first, then the stalest, and the rest carry
        their stale reading or report their verdict with the reading put off.  So a cold start of
        thousands of sticky loops, or a take-over, spreads its readings over the next reports instead of
        making every report late."""
        out, wanting = [], []
        every = self.settings.estimate_every
        queue, self._queue = self._queue, []  # loops that became due as they were ingested, in that order
        for loop_id in queue:
            state = self.loops[loop_id]
            state.queued = False
            w = state.window
            if not self._is_due(state):  # its window restarted since
                continue
            # the replica keeps the owner's schedule without reporting, so that after a take-over it
            # reports each interval once, on time, not at once with everything it has counted
            state.new_since_report = 0
            if not self.owns(loop_id) or (w.t_end_s is not None and w.t_end_s <= state.reported_to_s):
                continue  # another agent's, or reported already by the owner that has just died
            # a loop last called not sticky has no reading to carry and is read at once should it turn
            # sticky, outside the ration; the others want a reading when theirs is missing or stale
            kept = now_s is not None and now_s < state.kept_until_s
            if state.reading is not None and state.reading_reports >= every and not kept:
                wanting.append((state.reading_reports, len(out)))
            elif state.reading is None and state.verdict in (None, "stiction"):
                wanting.append((math.inf, len(out)))
            out.append(Due(loop_id, state.arrived_at, state.interpolated(), carry=state.reading))
        behind = now_s is not None and bool(out) and now_s - min(d.arrived_s for d in out) > self.settings.reading_lag_s
        grant = -(-len(out) // every) if behind else len(wanting)
        wanting.sort(key=lambda x: -x[0])  # never read first, then the stalest
        for k, (_, i) in enumerate(wanting):
            if k < grant:
                out[i] = dataclasses.replace(out[i], carry=None)
            else:
                out[i] = dataclasses.replace(out[i], defer_reading=True)
                self.readings_deferred += 1
        return out

    def window(self, due: Due) -> Window:
        """The due loop's window, built from its samples held: valid until the next ``ingest`` or
        ``set_agents``, which may change or drop them."""
        extra = {"interpolated": due.interpolated, "carry": due.carry, "defer_reading": due.defer_reading}
        return self._window(due.loop_id, self.loops[due.loop_id], **extra)

    def _window(self, loop_id: str, state: _Loop, **extra) -> Window:
        """The loop's samples held, as the pipeline's ``Window``."""
        w, full = state.window, self.settings.window_samples
        op, pv = w.get()
        return Window(loop_id, op, pv, w.ts_s, w.t_end_s, state.process, sp=w.get_sp(), full_samples=full,
                      mv=w.get_mv(), **extra)  # fmt: skip

    def window_of(self, loop_id: str) -> Window | None:
        """The owned loop's window as it stands (for the background sizing), or None."""
        state = self.loops.get(loop_id)
        if state is None or not self.owns(loop_id) or not state.window.count:
            return None
        return self._window(loop_id, state)

    def seen_report(self, key: str, payload: bytes) -> None:
        """A report on the key space (from any agent): the loop's windows up to its end are reported.
        Only the end time is read; anything unreadable is ignored (it cannot stop a report)."""
        loop_id = keys.loop_id_of(self.settings.prefix, key)
        if loop_id is None:
            return
        try:
            t_end_s = json.loads(payload).get("t_end_s")
        except (ValueError, AttributeError):
            return
        if isinstance(t_end_s, int | float):
            self._reported_to(loop_id, float(t_end_s))

    def _reported_to(self, loop_id: str, t_end_s: float) -> None:
        t_end_s = max(self.reported_to_s.get(loop_id, -math.inf), t_end_s)
        self.reported_to_s[loop_id] = t_end_s
        state = self.loops.get(loop_id)
        if state is not None:
            state.reported_to_s = t_end_s

    def reported(self, loop_id: str, verdict: str, reading: Reading | None, t_end_s: float | None = None) -> None:
        """A report went out (of the window ending at ``t_end_s``): keep its fresh friction reading, count a
        carried one, or drop the loop's reading once it is no longer called sticky.  The window's end is kept as
        a report seen on the key space is (``seen_report``): the service does not hear its own reports back."""
        if t_end_s is not None:
            self._reported_to(loop_id, t_end_s)
        state = self.loops.get(loop_id)
        if state is None:
            return
        state.verdict = verdict
        if reading is not None:
            state.reading, state.reading_reports, state.kept_until_s = reading, 1, -math.inf
        elif verdict == "stiction" and state.reading is not None:
            state.reading_reports += 1
        elif verdict != "stiction":
            state.reading, state.kept_until_s = None, -math.inf

    def adopt(self, loop_id: str, reading: Reading, keep_until_s: float) -> bool:
        """A reading made in the background (a fit of the loop's window, ``quantify.refit``) becomes the loop's:
        its next reports carry it, and none reads afresh before ``keep_until_s`` (``due_loops``' clock).  Only
        for a loop held and still called sticky; whether it was taken."""
        state = self.loops.get(loop_id)
        if state is None or state.verdict != "stiction":
            return False
        state.reading, state.reading_reports, state.kept_until_s = reading, 1, keep_until_s
        return True

    def completed(self, n_reports: int, arrivals: list[float], now_s: float) -> None:
        self.reports += n_reports
        self.latencies.extend(now_s - a for a in arrivals)
        del self.latencies[:-5000]

    def pending(self) -> int:
        return sum(1 for s in self.loops.values() if s.new_since_report >= self.settings.report_every_samples)

    def latency_percentiles(self) -> tuple[float | None, float | None]:
        if not self.latencies:
            return None, None
        lat = np.asarray(self.latencies)
        return float(np.percentile(lat, 50)), float(np.percentile(lat, 99))


def _reason(error: ValidationError) -> str:
    first = error.errors()[0]
    kind, loc = first["type"], first["loc"]
    if kind == "json_invalid":
        return "malformed_json"
    if loc and loc[0] == "schema_version":
        return "wrong_schema_version"
    if kind == "missing":
        return "missing_field"
    if kind == "finite_number":
        return "not_finite"
    if kind == "too_long":
        return "oversized_batch"
    return "invalid_field"
