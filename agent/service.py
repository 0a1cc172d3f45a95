"""The agent on Zenoh: the only module of the agent that talks to it.

The subscriber callback only queues ``(key, payload, encoding, arrival, history)``: Zenoh
runs callbacks on one thread holding the GIL.  One worker loop drains the queue into
the pure core, quantifies the windows that are due in batches, and publishes their
reports.  Liveliness tokens of ``{prefix}/agent/*`` give the set of live agents, and
with it which shards are this agent's: it subscribes to those shards' sample keys only (and
to the spec's unsharded key, which every agent receives), and asks the publishers for the
recent samples of a shard it takes over.
"""

from __future__ import annotations

import logging
import threading
import time
import zlib
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from stiction.agent.core import AgentCore, CoreSettings
from stiction.agent.sizing_plan import SizingPlan
from stiction.quantify.assembly import assemble, needs_sizing
from stiction.quantify.identified import lower_priority, size_in_worker, sizing_pool, stop_pool
from stiction.quantify.pipeline import Quantifier, warm_up
from stiction.quantify.refit import fit_in_worker, worker_window
from stiction.quantify.stem import stem_check
from stiction.schemas import keys
from stiction.schemas.errors import StictionError, as_stiction_error
from stiction.schemas.messages import AgentHealth, LoopTruth
from stiction.schemas.report import StictionReport

log = logging.getLogger(__name__)


INGEST_PER_PASS = 1000
"""Messages ingested before the worker looks for due windows: a window due early in a burst of
thousands of messages is reported without waiting for the whole burst."""
HISTORY_TIMEOUT_S = 30.0
"""How long the publishers have to answer for a shard's recent samples."""
LATEST_LEVEL = 1
"""zlib's level for the latest reports an agent holds: a sticky loop's report is 1.4 kB of JSON and 0.7 kB
compressed, 14 MB less for 20,000 loops, for 20-40 us a report (1 % of a core at 300 reports a second)."""
BACKLOG_MESSAGES = 20000
"""Past this many queued messages the agent is behind: it ingests them all first, so the queue
stays bounded and reports are late rather than samples stranded."""
SAMPLE_CHANNEL = 1 << 16
"""Samples a subscription's channel holds before Zenoh waits for the worker to drain it.  Samples come
through channels the worker drains, not callbacks: a callback per message took the GIL from Zenoh's
thread 10,000 times a second, 0.29 of a core at 10,000 loops (``stiction bench throughput``).  The
worker drains them between every thousand messages it ingests and every batch of reports: a sample
waiting in a channel holds on to the network buffer it arrived in, and a survivor taking over a dead
agent's loops, busy with their history, peaked at 0.9-1 GB with 2^20 samples a channel where the
callbacks' copies had 540 MB; 2^16 (6.5 s of 10,000 loops) 680 MB, and a full channel makes Zenoh wait,
which the publishers' congestion control (BLOCK) turns into back-pressure, not loss."""
IDLE_WAIT_S = 0.02
"""How long an idle worker waits before it drains the channels again (samples do not wake it)."""


@dataclass(frozen=True)
class AgentSettings:
    """The agent process's settings: the core's (windows, reports, ownership: ``CoreSettings``, passed
    down as they are) and those of its Zenoh edge."""

    agent_id: str
    core: CoreSettings = CoreSettings()
    models_dir: Path | None = None
    health_every_s: float = 2.0
    max_batch: int = 200
    """Windows quantified together at most (the pipeline batches them)."""
    size_every_s: float = 3600.0
    """A loop called sticky whose process is unknown has it identified and S and J read under it once
    in this long, on a worker process of lowered priority (``agent.sizing_plan``); 0: never."""
    size_workers: int = 1
    """Worker processes for those sizings, each one loop at a time (seconds of CPU a loop: about 1,000 loops an
    hour a worker here, docs/scaling.md); a loop waits in a queue while every worker is busy."""

    @property
    def prefix(self) -> str:
        return self.core.prefix


def quantify_isolated(quantify, windows: list, reject) -> list:
    """``quantify(windows)``'s results; if the batch fails, each window alone, so that one bad window (or a
    fault of ours in one) costs only its own report: None in its place, and ``reject(reason, message)``
    says why in the health message's counts."""
    try:
        return list(quantify(windows))
    except Exception:
        pass
    results = []
    for w in windows:
        try:
            results.extend(quantify([w]))
        except Exception as e:
            if not isinstance(e, StictionError):
                log.exception("quantifying %s failed", w.loop_id)
            said = str(as_stiction_error(e))
            reject("window_refused", said if w.loop_id in said else f"{w.loop_id}: {said}")
            results.append(None)
    return results


SEQUENCE_CHUNKS = 1
"""The window network reads the last 600 samples of a loop's window in the agent (its window is 1,000): the
network's cost is its chunks (0.37 ms each here, three networks), and at 10,000 plant-like loops a second chunk
of every window that does not cycle took the verdict stage from 0.11 to 0.23 of a core (``stiction bench
throughput --loops 10000 --mix plant``).  ``stiction quantify`` reads up to six chunks of an export."""

FIT_VALVE = False
"""The agent does not fit the valve to a noisy level loop's record (``ident.open_loop``) on the report's thread: at
1-3 s a window, one such loop would hold up every other loop's report.  It fits it on the sizing workers instead
(``quantify.refit``, once every ``size_every_s``), and the loop's next reports carry the fitted reading."""
KEEP_FIT = 2.0
"""An accepted fit's reading is carried for this many ``size_every_s`` (its refit comes after one)."""


class AgentService:
    def __init__(self, settings: AgentSettings, session, quantifier: Quantifier | None = None, sink=None):
        import zenoh

        self._zenoh = zenoh
        self.settings = settings
        self.session = session
        self.quantifier = quantifier or Quantifier(
            settings.models_dir, sequence_chunks=SEQUENCE_CHUNKS, fit_valve=FIT_VALVE
        )
        self.core = AgentCore(settings.agent_id, settings.core)
        self.latest: dict[str, bytes] = {}
        """Each loop's latest report for ``get``, compressed (``LATEST_LEVEL``)."""
        self.drafts: dict[str, StictionReport] = {}
        """The latest draft of each sticky loop of unknown process: its report is assembled again
        with a sizing that comes back (``quantify.assembly``)."""
        self._inbox: deque = deque()
        self._reports_seen: deque = deque()  # (key, payload) of reports published by any agent
        self._wake = threading.Event()
        self._alive: set[str] = set()
        self._alive_lock = threading.Lock()
        self._started = time.monotonic()
        self._last_health = 0.0
        self._rate_mark = (time.monotonic(), 0, 0)  # (time, samples, reports) at the last health message
        self._declared: list = []
        self.on_health = None  # optional: called with every health message (the command's status line)
        self.sink = sink  # optional viewer: log_report(report, window, details, truth)
        self.truths: dict[str, tuple[float, float]] = {}
        self.sink_errors = 0
        self.sizing = SizingPlan(settings.size_every_s, settings.size_workers) if settings.size_every_s > 0 else None
        self._size_pool = None
        self._sizings: dict = {}  # future -> (loop_id, t_end_s)
        self._fits: dict = {}  # future -> loop_id: the windows being fitted (``quantify.refit``)
        self._stems: dict = {}  # future -> loop_id: the measured stems being checked
        self._size_queue: dict[str, bool] = {}  # loops waiting for the worker (True: a fit), in the order they asked
        self._check_queue: dict[str, None] = {}  # loops whose slip reading waits to be checked, after the others
        self._shard_subs: dict[str, object] = {}  # key expression -> subscriber (a channel)
        self._spec_samples = None  # the subscriber (a channel) to the spec's sample key
        self._owned: set[int] = set()
        self._history_asked_at = -float("inf")
        self._history_wanted: list[int] = []  # shards taken on whose recent samples are still to be asked for
        self.messages_received = 0
        self._cpu_s = {"ingest": 0.0, "publish": 0.0}  # the worker thread's own stages besides the pipeline's
        self._worker_cpu_s = 0.0  # the worker thread's CPU seconds as of its last pass

    # samples: channels the worker drains ---------------------------------------------------------
    def _sample_subscriber(self, expr: str):
        return self.session.declare_subscriber(expr, self._zenoh.handlers.FifoChannel(SAMPLE_CHANNEL))

    def _drain(self) -> None:
        """Move every sample waiting in the subscriptions' channels to the inbox, stamped with this pass's time."""
        now, inbox = time.monotonic(), self._inbox
        for sub in (self._spec_samples, *self._shard_subs.values()):
            if sub is None:
                continue
            while (sample := sub.try_recv()) is not None:
                inbox.append((str(sample.key_expr), sample.payload.to_bytes(), str(sample.encoding), now, False))

    # zenoh callbacks: keep them tiny ------------------------------------------------------------
    def _on_history(self, reply) -> None:
        """A publisher's recent samples of one loop of a shard this agent has just taken on."""
        sample = reply.ok
        if sample is None:
            return
        self._inbox.append(
            (str(sample.key_expr), sample.payload.to_bytes(), str(sample.encoding), time.monotonic(), True)
        )
        self._wake.set()

    def _on_agent(self, sample) -> None:
        agent_id = keys.agent_id_of(self.settings.prefix, str(sample.key_expr))
        if agent_id is None:
            return
        with self._alive_lock:
            if sample.kind == self._zenoh.SampleKind.DELETE:
                self._alive.discard(agent_id)
            else:
                self._alive.add(agent_id)
        self._wake.set()

    def _on_report(self, sample) -> None:
        """Every other agent's reports: after a take-over, a window the old owner had already reported
        before it died is not reported again."""
        self._reports_seen.append((str(sample.key_expr), sample.payload.to_bytes()))
        self._wake.set()

    def _on_truth(self, sample) -> None:
        try:
            truth = LoopTruth.model_validate_json(sample.payload.to_bytes())
        except ValueError:
            return  # a viewer aid only: a bad truth message costs nothing else
        self.truths[truth.loop_id] = (truth.fs_pct, truth.fd_pct)

    def _on_query(self, query) -> None:
        loop_id = keys.loop_id_of(self.settings.prefix, str(query.key_expr))
        wanted = self.latest.keys() if loop_id in (None, "*") else [loop_id]
        for lid in list(wanted):
            payload = self.latest.get(lid)
            if payload is not None and self.core.owns(lid):
                query.reply(
                    keys.report(self.settings.prefix, lid),
                    zlib.decompress(payload),
                    encoding=self._zenoh.Encoding.APPLICATION_JSON,
                )

    # lifecycle ---------------------------------------------------------------------------------
    def start(self) -> AgentService:
        warm_up(FIT_VALVE)  # before the first samples: a first compile must not delay the first reports
        p, s = self.settings.prefix, self.session
        self._spec_samples = self._sample_subscriber(keys.all_samples(p))  # the spec's key: every agent
        self._declared = [
            s.liveliness().declare_subscriber(keys.all_agents(p), self._on_agent, history=True),
            s.liveliness().declare_token(keys.agent_token(p, self.settings.agent_id)),
            self._spec_samples,
            # other agents' reports only: its own come back otherwise (a Python call and a JSON parse each, a
            # fiftieth of a core at 20,000 loops); ``AgentCore.reported`` keeps their ends.  An agent has a session
            # of its own, so "remote" is every other agent
            s.declare_subscriber(keys.all_reports(p), self._on_report, allowed_origin=self._zenoh.Locality.REMOTE),
            s.declare_queryable(keys.all_reports(p), self._on_query),
        ]
        if self.sink is not None:  # the viewer shows the truth where the simulator publishes it
            self._declared.append(s.declare_subscriber(keys.all_truths(p), self._on_truth))
        self._sync_shards()
        log.info("agent %s listening on %s", self.settings.agent_id, keys.all_samples(p))
        return self

    def _ask_history(self) -> None:
        """Ask the publishers for the recent samples of one shard taken on, once the inbox is short and
        the last shard's answer has had time to come."""
        now = time.monotonic()
        if not self._history_wanted or len(self._inbox) > INGEST_PER_PASS or now < self._history_asked_at + 0.2:
            return
        self._history_asked_at = now
        k = self._history_wanted.pop(0)
        self.session.get(
            f"{keys.shard_samples(self.settings.prefix, k)}?last={self.settings.core.window_samples}",
            self._on_history,
            consolidation=self._zenoh.ConsolidationMode.NONE,
            timeout=HISTORY_TIMEOUT_S,
        )

    def _sync_shards(self) -> None:
        """Subscribe to the shards this agent owns among the live agents (one subscription for all of
        them when it is alone: Zenoh's cost per message grows with the subscriptions), drop the
        others, and ask the publishers for the recent samples of the shards it has just taken on."""
        p, owned = self.settings.prefix, self.core.owned_shards()
        every = len(owned) == keys.SHARDS
        wanted = {keys.shard_samples(p, "*")} if every else {keys.shard_samples(p, k) for k in owned}
        for expr in sorted(wanted - set(self._shard_subs)):  # the new first: no sample falls between the two
            self._shard_subs[expr] = self._sample_subscriber(expr)
        # what a subscription about to go holds comes in first (a channel cannot be read once undeclared); what
        # reaches it after this drain came to the new subscriptions too, or is of a shard no longer owned
        self._drain()
        for expr in [e for e in self._shard_subs if e not in wanted]:
            self._shard_subs.pop(expr).undeclare()
        new, self._owned = sorted(owned - self._owned), owned
        # asked for after subscribing (what comes live meanwhile is merged behind the history), one
        # shard at a time as the inbox empties (``_ask_history``): a dead agent's thousands of windows
        # do not land at once
        self._history_wanted = [k for k in self._history_wanted if k in owned] + new
        if new:
            log.info("agent %s: %d shards taken on, %d held", self.settings.agent_id, len(new), len(owned))

    def close(self) -> None:
        for d in [*reversed(self._declared), *self._shard_subs.values()]:
            d.undeclare()
        self._declared, self._shard_subs, self._spec_samples = [], {}, None
        if self._size_pool is not None:
            stop_pool(self._size_pool)  # a sizing in flight would hold the agent's exit until it ends
            self._size_pool = None

    def run(self, stop: threading.Event) -> None:
        while not stop.is_set():
            worked = self.step(stop)
            if not worked:
                self._wake.wait(IDLE_WAIT_S)
                self._wake.clear()
        self.publish_health()

    # one pass of the worker ----------------------------------------------------------------------
    def step(self, stop: threading.Event | None = None) -> bool:
        """Ingest what arrived, report what is due; a set ``stop`` ends the pass between batches (a
        backlogged agent stops within one batch of SIGTERM, not after its whole backlog)."""
        with self._alive_lock:
            alive = set(self._alive)
        if self.core.set_agents(alive):
            self._sync_shards()
        self._collect_sizings()
        self._collect_stems()
        self._collect_fits()
        while self._reports_seen:  # before any window is due: a report made elsewhere is never made twice
            self.core.seen_report(*self._reports_seen.popleft())
        clock = time.thread_time()
        self._drain()
        self._ask_history()
        n = 0
        limit = INGEST_PER_PASS if len(self._inbox) <= BACKLOG_MESSAGES else len(self._inbox)
        while self._inbox and n < limit:
            if n % INGEST_PER_PASS == 0:
                if stop is not None and stop.is_set():
                    return False
                if n:
                    self._drain()
            key, payload, encoding, arrived, history = self._inbox.popleft()
            self.messages_received += 1
            self.core.ingest(key, payload, encoding, arrived, history)
            n += 1
        due = self.core.due_loops(time.monotonic())
        now = time.thread_time()
        self._cpu_s["ingest"] += now - clock
        for i in range(0, len(due), self.settings.max_batch):
            if stop is not None and stop.is_set():
                return False
            in_pipeline = sum(self.quantifier.cpu_s.values())
            # each batch's windows built as it is quantified: copies of every due window at once fragment the heap
            self._report([(self.core.window(d), d.arrived_s) for d in due[i : i + self.settings.max_batch]])
            self._drain()  # the channels are short between batches: a sample held there pins Zenoh's buffer
            later = time.thread_time()
            self._cpu_s["publish"] += later - now - (sum(self.quantifier.cpu_s.values()) - in_pipeline)
            now = later
        self._worker_cpu_s = time.thread_time()
        if time.monotonic() - self._last_health >= self.settings.health_every_s:
            self.publish_health()
        return bool(n or due)

    def _quantify(self, windows):
        return self.quantifier.results(windows, details=self.sink is not None)

    def _report(self, due) -> None:
        results = quantify_isolated(self._quantify, [w for w, _ in due], self.core.reject)
        put_kw = {
            "encoding": self._zenoh.Encoding.APPLICATION_JSON,
            "congestion_control": self._zenoh.CongestionControl.BLOCK,
        }
        arrivals = []
        for (w, arrived), result in zip(due, results, strict=True):
            if result is None:
                continue
            draft, details = result.draft, result.details
            self.core.reported(w.loop_id, draft.verdict, result.reading, w.t_end_s)
            if self.sizing is None:
                report = assemble(draft, agent_id=self.settings.agent_id)
            else:
                if self.sizing.wanted(draft, time.monotonic()):
                    self._size_or_queue(w)
                elif self.sizing.fit_wanted(draft, time.monotonic()):
                    self._size_or_queue(w, fit=True)
                elif self.sizing.check_wanted(draft, result.unchecked, time.monotonic()):
                    self._check_or_queue(w)
                if self.sizing.stem_wanted(w.loop_id, w.mv is not None, len(w.op), time.monotonic()):
                    self._check_stem(w)
                report = self.sizing.apply(draft, self.settings.agent_id)
                if needs_sizing(draft):
                    self.drafts[w.loop_id] = draft
                else:
                    self.drafts.pop(w.loop_id, None)
            payload = report.model_dump_json().encode()
            self.latest[w.loop_id] = zlib.compress(payload, LATEST_LEVEL)
            self.session.put(keys.report(self.settings.prefix, w.loop_id), payload, **put_kw)
            arrivals.append(arrived)
            if self.sink is not None:
                try:
                    self.sink.log_report(report, w, details, self.truths.get(w.loop_id))
                except Exception:  # a viewer problem must never stop the reports
                    self.sink_errors += 1
                    if self.sink_errors == 1:
                        log.exception("rerun sink failed; reports go on without it")
        self.core.completed(len(arrivals), arrivals, time.monotonic())

    # background sizing ---------------------------------------------------------------------------
    def _size_or_queue(self, w, fit: bool = False) -> None:
        """Size (``fit``: fit) the window now if a worker is free, else queue the loop until one is, when its
        window is taken afresh from the rolling buffer (the newest; a loop whose stream ends while another is
        being sized is still sized).  The queue holds loop ids, not windows: a plant of thousands of sticky
        loops of unknown process waits in it, 12 kB a window copied."""
        if self.sizing.has_room():
            if fit:
                self._fit(w)
            else:
                self._size(*self._job(w))
        else:
            self._size_queue.pop(w.loop_id, None)  # in the order loops last asked
            self._size_queue[w.loop_id] = fit

    def _check_or_queue(self, w) -> None:
        """Check the window's trusted slip reading against the record on a worker (a fit where it falls short) if a
        worker is free and no sizing or fit waits, else queue the loop behind them."""
        if self.sizing.has_room() and not self._size_queue:
            self._fit(w)
        else:
            self._check_queue.pop(w.loop_id, None)
            self._check_queue[w.loop_id] = None

    @staticmethod
    def _job(w) -> tuple:
        sp = None if w.sp is None else np.array(w.sp)
        return (w.loop_id, np.array(w.op), np.array(w.pv), float(w.ts_s), w.t_end_s, w.partial, sp)

    def _size(self, loop_id, op, pv, ts_s, t_end_s, partial, sp=None) -> None:
        """Identify the loop's process and read S and J under it on the worker (copies: the window's
        arrays are views of the rolling buffer, and the pool pickles them later)."""
        future = self._pool().submit(size_in_worker, op, pv, ts_s, loop_id, sp)
        self._sizings[future] = (loop_id, t_end_s)
        self.sizing.started(loop_id, len(op), partial)

    def _fit(self, w) -> None:
        """Fit the valve to the loop's window on a worker (``quantify.refit``), as ``stiction quantify`` does."""
        future = self._pool().submit(fit_in_worker, worker_window(w), self.settings.models_dir, SEQUENCE_CHUNKS)
        self._fits[future] = w.loop_id
        self.sizing.fit_started(w.loop_id)

    def _collect_fits(self) -> None:
        """Fits that came back: an accepted one's reading is carried in the loop's next reports, and its report
        put into the loop's latest for ``get`` where it is of the window last reported (not published again)."""
        for loop_id, fitted in self._came_back(self._fits, "fit of %s's valve"):
            now = time.monotonic()
            self.sizing.fit_finished(loop_id, now)
            if fitted is None or not self.core.owns(loop_id):
                continue
            reading, draft = fitted
            if not self.core.adopt(loop_id, reading, now + KEEP_FIT * self.sizing.refresh_s):
                continue
            if draft.t_end_s is not None and draft.t_end_s == self.core.reported_to_s.get(loop_id):
                report = self.sizing.apply(draft, self.settings.agent_id)
                self.latest[loop_id] = zlib.compress(report.model_dump_json().encode(), LATEST_LEVEL)
        self._start_queued()

    def _pool(self):
        """The background workers (``size_workers`` processes of lowered priority), started when first needed."""
        if self._size_pool is None:
            self._size_pool = sizing_pool(self.settings.size_workers, initializer=lower_priority)
        return self._size_pool

    def _check_stem(self, w) -> None:
        """Check the loop's measured stem against OP on the worker (copies: the window's arrays are views)."""
        future = self._pool().submit(stem_check, np.array(w.op), np.array(w.mv), float(w.ts_s))
        self._stems[future] = w.loop_id
        self.sizing.stem_started(w.loop_id)

    @staticmethod
    def _came_back(futures: dict, what: str):
        """(what was kept with each job that is done, its result), taken out of ``futures``; a worker that died or
        failed costs that job only: its result is None, and the log says which (``what`` of the loop id)."""
        for future in [f for f in futures if f.done()]:
            job = futures.pop(future)
            try:
                result = future.result()
            except Exception:
                log.exception("background %s failed", what % (job[0] if isinstance(job, tuple) else job))
                result = None
            yield job, result

    def _collect_stems(self) -> None:
        """Stem checks that came back: kept for the loop's next reports."""
        for loop_id, result in self._came_back(self._stems, "check of %s's measured stem"):
            self.sizing.stem_finished(loop_id, result, time.monotonic())

    def _collect_sizings(self) -> None:
        """Sizings that came back: kept for the loop's next reports, and put into its latest report
        for ``get`` at once (not published again: a window is reported exactly once)."""
        for (loop_id, t_end_s), sizing in self._came_back(self._sizings, "sizing of %s"):
            self.sizing.finished(loop_id, sizing, t_end_s, time.monotonic())
            draft = self.drafts.get(loop_id)
            if draft is None or not self.core.owns(loop_id):
                continue
            report = self.sizing.apply(draft, self.settings.agent_id)
            self.latest[loop_id] = zlib.compress(report.model_dump_json().encode(), LATEST_LEVEL)
        self._start_queued()

    def _start_queued(self) -> None:
        """The queued loops' sizings and fits, then their slip readings' checks, as workers come free, each on the
        loop's window as it is now."""
        while (self._size_queue or self._check_queue) and self.sizing.has_room():
            if self._size_queue:
                loop_id = next(iter(self._size_queue))
                fit = self._size_queue.pop(loop_id)
            else:
                loop_id, fit = next(iter(self._check_queue)), True
                del self._check_queue[loop_id]
                if not self.sizing.fit_due(loop_id, time.monotonic()):
                    continue  # fitted meanwhile (its reading was left unfitted since)
            w = self.core.window_of(loop_id)
            if w is None:  # handed to another agent, or its window restarted empty
                continue
            if fit:
                self._fit(w)
            else:
                self._size(*self._job(w))

    def health(self, advance_rates: bool = False) -> AgentHealth:
        """The counters; rates are over the time since the last published health message."""
        p50, p99 = self.core.latency_percentiles()
        owned = sum(1 for lid in self.core.loops if self.core.owns(lid))
        t0, samples0, reports0 = self._rate_mark
        now = time.monotonic()
        span = now - t0
        if advance_rates:
            self._rate_mark = (now, self.core.samples, self.core.reports)
        return AgentHealth(
            agent_id=self.settings.agent_id,
            uptime_s=time.monotonic() - self._started,
            agents_alive=list(self.core.agents),
            loops_seen=len(self.core.loops),
            loops_owned=owned,
            samples=self.core.samples,
            reports=self.core.reports,
            rejected=dict(self.core.rejected),
            latency_p50_s=p50,
            latency_p99_s=p99,
            pending_loops=self.core.pending(),
            samples_per_s=(self.core.samples - samples0) / span if span > 0 else None,
            reports_per_s=(self.core.reports - reports0) / span if span > 0 else None,
            gaps_filled=self.core.gaps_filled,
            samples_filled=self.core.samples_filled,
            readings_deferred=self.core.readings_deferred,
            loops_sized=self.sizing.done if self.sizing is not None else 0,
            loops_fitted=self.sizing.fits_done if self.sizing is not None else 0,
            cpu_s=self.cpu_profile(),
            messages_received=self.messages_received,
            shards_owned=len(self._owned),
            windows_from_history=self.core.history_merged,
        )

    def cpu_profile(self) -> dict[str, float]:
        """CPU seconds by stage since the start: the worker's ingest (decoding, windows), the pipeline's
        stages, publishing; ``zenoh_and_callbacks`` is the rest of the process (Zenoh's threads, the
        subscriber callbacks, the sizing's hand-off, start-up)."""
        worker = {**self._cpu_s, **self.quantifier.cpu_s}
        rest = time.process_time() - self._worker_cpu_s
        return {k: round(v, 3) for k, v in (worker | {"zenoh_and_callbacks": max(rest, 0.0)}).items()}

    def publish_health(self) -> AgentHealth:
        self._last_health = time.monotonic()
        health = self.health(advance_rates=True)
        self.session.put(
            keys.agent_health(self.settings.prefix, self.settings.agent_id),
            health.model_dump_json().encode(),
            encoding=self._zenoh.Encoding.APPLICATION_JSON,
        )
        if self.on_health is not None:
            self.on_health(health)
        return health
