"""The OPC UA edge of the bridge: subscribe to every loop's nodes, feed the sampler, publish its batches.

One asyncio task keeps a client connected (reconnecting by itself with a short back-off after
the server goes away), one drains the subscription's notifications into the sampler, one ticks
the sampler on the loops' grid and hands each batch to ``publish``.  Nothing here knows Zenoh:
``publish(batch)`` (a ``SampleBatch``'s fields) and ``on_health(health)`` are the caller's.
"""

from __future__ import annotations

import asyncio
import contextlib
import datetime as dt
import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from stiction.bridge.publish import stagger_groups
from stiction.bridge.sampler import Reading, Sampler
from stiction.schemas.errors import InputError
from stiction.schemas.loop_file import LoopFile
from stiction.schemas.messages import BridgeHealth

log = logging.getLogger(__name__)

SUBSCRIBE_CHUNK = 500
"""Monitored items created per request: a plant's thousands of nodes in a few round trips."""
EVENT_QUEUE = 200_000
"""Notifications buffered between the client and the sampler (tens of seconds for 1,000 loops)."""
GONE = {"BadNodeIdUnknown", "BadNodeIdInvalid", "BadNodeIdRejected", "BadAttributeIdInvalid"}
"""Status codes that mean the node is not there (the loop is reported missing, not just a bad value)."""


@dataclass(frozen=True)
class BridgeSettings:
    bridge_id: str
    endpoint: str
    security: str | None = None
    user: str | None = None
    password: str | None = None
    request_timeout_s: float = 4.0
    health_every_s: float = 2.0
    max_backoff_s: float = 2.0
    application_uri: str = "urn:stiction:bridge"
    """Must match the URI in the client certificate where security is used."""
    watchdog_s: float = 10.0
    """asyncua's own liveness probe: its interval and timeout.  A server that closes the socket is
    noticed at once; this only bounds how long a silent, half-open connection goes unnoticed."""
    batch_s: float | None = None
    """A loop's samples of this many seconds go out in one message (``stiction bridge opcua --rate``), its loops
    spread over the interval, a group every sample time (``bridge.publish.stagger_groups``); None: each sample as
    it settles, every loop at once.  An agent's cost per message, not per sample, is what limits it at one sample
    a message (docs/scaling.md): five seconds a message carried 20,000 loops where one did not."""


class OpcuaBridge:
    def __init__(
        self,
        loop_file: LoopFile,
        settings: BridgeSettings,
        publish: Callable[[dict], None],
        on_health: Callable[[BridgeHealth], None] | None = None,
        clock: Callable[[], float] = time.time,
    ):
        self.loop_file = loop_file
        self.settings = settings
        self.sampler = Sampler(loop_file.loops, loop_file.sample_time_s)
        ids = list(loop_file.loops)
        self.message_every_s = max(settings.batch_s or 0.0, loop_file.sample_time_s)
        """How many seconds of a loop's samples go out a message: ``batch_s``, at least a sample time."""
        groups = stagger_groups(len(ids), self.message_every_s, loop_file.sample_time_s)
        self._groups = [[ids[j] for j in g] for g in groups]
        """The loops asked for their samples at each tick in turn (one group: every loop at every tick)."""
        self.publish = publish
        self.on_health = on_health
        self.clock = clock
        self.connected = False
        self.reconnects = 0
        self._sessions = 0
        self._started = time.monotonic()
        self._by_node: dict = {}
        self._last_reading = 0.0  # monotonic time of the last notification

    # the three tasks -------------------------------------------------------------------------------
    async def run(self, stop: asyncio.Event) -> None:
        ticker = asyncio.create_task(self._tick(stop))
        try:
            backoff = 0.25
            while not stop.is_set():
                try:
                    await self._session(stop)
                    backoff = 0.25
                except Exception as e:  # any failure of the connection: say it, mark a gap, try again
                    if self._sessions == 0 and _refused(e):  # the server is there and says no: retrying won't help
                        raise InputError(
                            f"OPC UA {self.settings.endpoint} refused the bridge: {_one_line(e)}"
                        ) from None
                    if self.connected or self._sessions == 0:
                        log.warning("OPC UA %s: %s", self.settings.endpoint, _one_line(e))
                    else:
                        log.info("OPC UA %s still unreachable: %s", self.settings.endpoint, _one_line(e))
                if self.connected:
                    self.sampler.disconnected(self.sampler.server_time(self.clock()))
                    self.connected = False
                if not stop.is_set():
                    await _wait(stop, backoff)
                    backoff = min(2 * backoff, self.settings.max_backoff_s)
        finally:
            ticker.cancel()
            self._publish_due()
            self._health()

    async def _session(self, stop: asyncio.Event) -> None:
        from asyncua import Client

        s = self.settings
        # asyncua's own watchdog probes the server every watchdog_intervall with that as the timeout: at its
        # default of 1 s a busy server (thousands of loops) is declared lost while it is sending values
        client = Client(s.endpoint, timeout=s.request_timeout_s, watchdog_intervall=s.watchdog_s)
        client.application_uri = s.application_uri
        if s.user:
            client.set_user(s.user)
        if s.password:
            client.set_password(s.password)
        if s.security:
            await client.set_security_string(s.security)
        await asyncio.wait_for(client.connect(), s.request_timeout_s * 2)
        try:
            sub = await self._subscribe(client)
            if self._sessions:
                self.reconnects += 1
                log.warning("OPC UA %s: reconnected (reconnect %d)", s.endpoint, self.reconnects)
            self._sessions += 1
            self.connected = True
            drain = asyncio.create_task(self._drain(sub))
            try:
                while not stop.is_set() and not drain.done():
                    # a dead server does not always close the socket: where no value came for a while,
                    # ask it something (a busy server that keeps sending values is alive, if slow to answer)
                    if time.monotonic() - self._last_reading > 2 * max(1.0, self.loop_file.sample_time_s):
                        await asyncio.wait_for(client.nodes.server_state.read_value(), s.watchdog_s)
                    await _wait(stop, 1.0)
            finally:
                drain.cancel()
            if drain.done() and not drain.cancelled() and drain.exception() is not None:
                raise drain.exception()
        finally:
            try:
                await asyncio.wait_for(client.disconnect(), 2.0)
            except Exception:  # the server may already be gone: nothing to close politely
                client.disconnect_socket()

    async def _subscribe(self, client):
        from asyncua import ua
        from asyncua.common.subscription import OverflowPolicy

        ts_ms = self.loop_file.sample_time_s * 1000
        sub = await client.create_subscription(
            ts_ms, None, queue_maxsize=EVENT_QUEUE, overflow=OverflowPolicy.DROP_NEWEST
        )
        if hasattr(sub, "_handle_overflow"):  # count what asyncua would drop silently
            sub._handle_overflow = lambda _event: self.sampler.dropped.update(["client_queue_full"])
        nodes, roles = [], []
        self._by_node = {}
        now = self.sampler.server_time(self.clock())
        for loop_id, loop in self.loop_file.loops.items():
            for role, text in loop.nodes().items():
                try:
                    node_id = ua.NodeId.from_string(text)
                except Exception:
                    self.sampler.node_missing(loop_id, role, "not a node id this server's client can parse", now)
                    continue
                node = client.get_node(node_id)
                nodes.append(node)
                roles.append((loop_id, role))
                self._by_node.setdefault(node.nodeid, []).append((loop_id, role))
        for i in range(0, len(nodes), SUBSCRIBE_CHUNK):
            chunk = nodes[i : i + SUBSCRIBE_CHUNK]
            results = await sub.subscribe_data_change(
                chunk, queuesize=max(10, int(10_000 / ts_ms)), sampling_interval=ts_ms / 2
            )
            for (loop_id, role), result in zip(roles[i : i + SUBSCRIBE_CHUNK], results, strict=True):
                if isinstance(result, ua.StatusCode):
                    self.sampler.node_missing(loop_id, role, result.name, now)
        return sub

    async def _drain(self, sub) -> None:
        from asyncua.common.subscription import DataChangeEvent, StatusChangeEvent

        async for event in sub:
            if isinstance(event, DataChangeEvent):
                self._reading(event)
            elif isinstance(event, StatusChangeEvent):
                log.warning("OPC UA subscription status: %s", event.notification.Status)

    def _reading(self, event) -> None:
        self._last_reading = time.monotonic()
        value = event.data.monitored_item.Value
        status = getattr(value, "StatusCode", None)
        good = status is None or status.is_good() or not status.is_bad()  # uncertain values are kept
        source = value.SourceTimestamp or value.ServerTimestamp
        source_s = _epoch_s(source) if source is not None else None
        arrived = self.clock()
        for loop_id, role in self._by_node.get(event.node.nodeid, ()):
            if not good and status.name in GONE:
                self.sampler.node_missing(loop_id, role, status.name, source_s or self.sampler.server_time(arrived))
                continue
            self.sampler.add(Reading(loop_id, role, event.value, good, source_s, arrived))

    async def _tick(self, stop: asyncio.Event) -> None:
        ts = self.loop_file.sample_time_s
        last_health = 0.0
        while not stop.is_set():
            self._publish_due()
            if time.monotonic() - last_health >= self.settings.health_every_s:
                last_health = time.monotonic()
                self._health()
            now = self.sampler.server_time(self.clock())
            await _wait(stop, ts - (now % ts) + min(0.05, ts / 10))  # just after the next grid point

    # out --------------------------------------------------------------------------------------------
    def _publish_due(self) -> None:
        """The settled samples of the loops whose turn it is (every loop's, unless ``batch_s``) to ``publish``."""
        now = self.sampler.server_time(self.clock())
        groups = self._groups
        turn = None if len(groups) < 2 else groups[math.floor(now / self.sampler.ts_s) % len(groups)]
        for batch in self.sampler.due(now, turn):
            self.publish(batch)

    def health(self) -> BridgeHealth:
        s = self.sampler
        return BridgeHealth(
            bridge_id=self.settings.bridge_id,
            source=self.settings.endpoint,
            connected=self.connected,
            uptime_s=time.monotonic() - self._started,
            loops=len(self.loop_file.loops),
            loops_publishing=len(s.publishing),
            samples_published=s.samples_published,
            dropped=dict(s.dropped),
            reconnects=self.reconnects,
            loops_missing=dict(s.missing),
        )

    def _health(self) -> None:
        if self.on_health is not None:
            self.on_health(self.health())


def _epoch_s(t: dt.datetime) -> float:
    """OPC UA times are UTC; asyncua gives naive datetimes for them."""
    return (t if t.tzinfo is not None else t.replace(tzinfo=dt.UTC)).timestamp()


async def _wait(stop: asyncio.Event, seconds: float) -> None:
    with contextlib.suppress(TimeoutError):
        await asyncio.wait_for(stop.wait(), max(seconds, 0.0))


REFUSALS = ("No matching endpoints", "BadSecurity", "BadCertificate", "BadIdentityToken", "BadUserAccessDenied")


def _refused(e: BaseException) -> bool:
    """The server answered and refused this client (security, certificate, credentials)."""
    text = f"{type(e).__name__} {e}"
    return any(r in text for r in REFUSALS)


def _one_line(e: BaseException) -> str:
    text = str(e).strip().splitlines()[0] if str(e).strip() else ""
    return f"{type(e).__name__}: {text}" if text else type(e).__name__
