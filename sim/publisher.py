"""``stiction sim``: many simulated, noisy loops streamed over Zenoh (the simulator's only Zenoh module).

Each loop has its own fs/fd, disturbance and seed; the batch simulator advances all of
them together.  Samples go out through ``bridge.publish`` (sharded keys, congestion control
BLOCK, the recent samples answered on ``get``).  Each loop's truth is put once and answered on
``get`` for late joiners.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from stiction.bridge.publish import SamplePublisher, stagger_groups
from stiction.schemas import keys
from stiction.schemas.messages import LoopTruth
from stiction.sim.grid import random_disturbance
from stiction.sim.loop import LoopSpec
from stiction.sim.stream import LoopStream
from stiction.sim.valve import band_and_jump_pct

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class PublisherSettings:
    prefix: str = keys.DEFAULT_PREFIX
    loops: int = 100
    seed: int = 0
    speed: float = 1.0
    """Simulated seconds per wall-clock second."""
    rate_hz: float = 1.0
    """Messages per second per loop; each carries ``speed / rate_hz`` samples."""
    stagger: bool = True
    """Spread the loops' messages over each interval (``bridge.publish.stagger_groups``), as a bridge
    does; False sends every loop's in the same instant."""
    warmup_s: float = 1000.0
    noise_free_share: float = 0.25
    duration_s: float | None = None
    """Stop after this much simulated time (None: until stopped)."""
    sharded: bool = True
    """Samples on each loop's shard key (agents receive their own shards only); False: the spec's key."""
    history_samples: int = 1000
    """Recent samples of each loop kept to answer an agent that takes a shard over (0: none)."""


def loop_specs(n: int, seed: int, noise_free_share: float = 0.25) -> dict[str, LoopSpec]:
    """``sim-00000``...: random fs in 4..100 %, fd below it, most with a random disturbance."""
    rng = np.random.default_rng(seed)
    specs = {}
    for i in range(n):
        fs = float(rng.uniform(4, 100))
        fd = float(fs * rng.uniform(0, 0.95))
        noisy = rng.uniform() >= noise_free_share
        d = random_disturbance(rng) if noisy else None
        specs[f"sim-{i:05d}"] = LoopSpec(fs, fd, disturbance=d, seed=int(rng.integers(2**31)))
    return specs


def truth_message(loop_id: str, spec: LoopSpec) -> LoopTruth:
    s_pct, j_pct = band_and_jump_pct(spec.fs_pct, spec.fd_pct)
    return LoopTruth(
        loop_id=loop_id,
        fs_pct=spec.fs_pct,
        fd_pct=spec.fd_pct,
        s_pct=float(s_pct),
        j_pct=float(j_pct),
        loop=spec.loop,
        valve=spec.valve,
        seed=spec.seed,
        disturbance=None if spec.disturbance is None else spec.disturbance.label(),
        extensions=spec.extensions.active(),
    )


def batch(loop_id: str, seq: int, t0_s: float, ts_s: float, op, pv, sp, process) -> dict:
    """A ``SampleBatch``'s fields, for ``bridge.publish.SamplePublisher.put``."""
    return dict(loop_id=loop_id, seq=seq, t0_s=t0_s, ts_s=ts_s, op=op, pv=pv, sp=sp, process=process)


def run(
    settings: PublisherSettings, session, stop: threading.Event, on_tick: Callable[[int], None] | None = None
) -> int:
    """Publish until ``stop`` is set (or ``duration_s``); returns the samples published per loop."""
    import zenoh

    specs = loop_specs(settings.loops, settings.seed, settings.noise_free_share)
    ids = list(specs)
    truths = {i: truth_message(i, s).model_dump_json().encode() for i, s in specs.items()}
    json_enc = zenoh.Encoding.APPLICATION_JSON
    for loop_id, payload in truths.items():
        session.put(keys.truth(settings.prefix, loop_id), payload, encoding=json_enc)

    def answer_truth(query) -> None:
        loop_id = keys.loop_id_of(settings.prefix, str(query.key_expr))
        for lid in [loop_id] if loop_id in truths else ids if loop_id in (None, "*") else []:
            query.reply(keys.truth(settings.prefix, lid), truths[lid], encoding=json_enc)

    queryable = session.declare_queryable(keys.all_truths(settings.prefix), answer_truth)
    out = SamplePublisher(session, settings.prefix, settings.sharded, settings.history_samples)
    stream = LoopStream(list(specs.values()))
    ts = stream.ts_s
    if settings.warmup_s > 0:
        stream.next(int(settings.warmup_s / ts))
    process = ["level" if s.loop == "level" and not s.extensions.active() else None for s in specs.values()]
    per_tick = settings.speed / settings.rate_hz / ts  # samples per message
    groups = stagger_groups(len(ids), 1.0 / settings.rate_hz) if settings.stagger else [np.arange(len(ids))]
    started = time.monotonic()
    owed, published, tick = 0.0, 0, 0
    log.info("publishing %d loops at %gx real time, %.3g samples a message", len(ids), settings.speed, per_tick)
    try:
        while not stop.is_set():
            owed += per_tick
            n = int(owed)
            if n:
                owed -= n
                chunk = stream.next(n)
                for k, group in enumerate(groups):  # spread over the tick, not all in one instant
                    if k:
                        stop.wait(max(0.0, started + (tick + k / len(groups)) / settings.rate_hz - time.monotonic()))
                    for j in group:
                        op, pv, sp = chunk.op[j], chunk.pv[j], chunk.sp[j]
                        out.put(batch(ids[j], chunk.seq, chunk.t0_s, ts, op, pv, sp, process[j]))
                published += n
            tick += 1
            if on_tick:
                on_tick(published)
            if settings.duration_s is not None and published * ts >= settings.duration_s:
                break
            delay = started + tick / settings.rate_hz - time.monotonic()
            if delay > 0:
                stop.wait(delay)
    finally:
        out.close()
        queryable.undeclare()
    return published
