"""The publishers' Zenoh edge: samples on the loops' shard keys, and their recent history on ``get``."""

import threading
import time

import numpy as np
import zenoh

from stiction.bridge import zenoh_session
from stiction.bridge.publish import SamplePublisher
from stiction.schemas import keys
from stiction.schemas.messages import SampleBatch
from tests.integration.conftest import wait_until

PREFIX = "test/history"


def test_an_agent_subscribed_to_one_shard_gets_only_its_loops_and_their_history_on_get():
    endpoint = zenoh_session.free_loopback_endpoint()
    loops = [f"FIC{i}" for i in range(30)]
    shard = keys.shard_of(loops[0])
    mine = {lid for lid in loops if keys.shard_of(lid) == shard}
    got: list[str] = []
    lock = threading.Lock()

    def on_sample(sample):
        with lock:
            got.append(SampleBatch.model_validate_json(sample.payload.to_bytes()).loop_id)

    with (
        zenoh.open(zenoh_session.build([endpoint])) as pub_s,
        zenoh.open(zenoh_session.build(connect=[endpoint], listen=[zenoh_session.free_loopback_endpoint()])) as sub_s,
    ):
        sub = sub_s.declare_subscriber(keys.shard_samples(PREFIX, shard), on_sample)
        out = SamplePublisher(pub_s, PREFIX, keep_samples=40)
        threading.Event().wait(0.5)  # the subscription reaches the publisher's session
        for seq in range(0, 50, 10):
            for lid in loops:
                op = np.arange(seq, seq + 10, dtype=float)
                out.put({"loop_id": lid, "seq": seq, "t0_s": float(seq), "ts_s": 1.0, "op": op, "pv": op / 2})
        wait_until(lambda: len(got) >= 5 * len(mine), 10, "the shard's samples")
        assert set(got) == mine  # no other shard's loop reached this subscriber
        replies = [r.ok for r in sub_s.get(f"{keys.shard_samples(PREFIX, shard)}?last=25", timeout=5) if r.ok]
        batches = {SampleBatch.model_validate_json(s.payload.to_bytes()).loop_id: s for s in replies}
        assert set(batches) == mine
        b = SampleBatch.model_validate_json(batches[loops[0]].payload.to_bytes())
        assert b.seq == 25 and b.op == list(np.arange(25, 50, dtype=float)) and b.pv == [x / 2 for x in b.op]
        assert str(batches[loops[0]].key_expr) == keys.sharded_samples(PREFIX, loops[0])
        bad = list(sub_s.get(f"{keys.shard_samples(PREFIX, shard)}?last=all", timeout=5))  # not a number
        assert len(bad) == 1 and bad[0].ok is None and b"last" in bad[0].err.payload.to_bytes()
        sub.undeclare()
        out.close()


def test_a_publisher_that_waits_for_subscribers_loses_no_first_batch_to_a_late_subscription():
    endpoint = zenoh_session.free_loopback_endpoint()
    loops = [f"LIC{i}" for i in range(160)]
    shard = keys.shard_of(loops[0])
    mine = [lid for lid in loops if keys.shard_of(lid) == shard]
    others = [lid for lid in loops if keys.shard_of(lid) != shard]
    got: list[int] = []

    with (
        zenoh.open(zenoh_session.build([endpoint])) as pub_s,
        zenoh.open(zenoh_session.build(connect=[endpoint], listen=[zenoh_session.free_loopback_endpoint()])) as sub_s,
    ):
        out = SamplePublisher(pub_s, PREFIX, keep_samples=0)
        late = threading.Timer(0.3, lambda: got.append(0) or subs.append(
            sub_s.declare_subscriber(keys.shard_samples(PREFIX, shard), lambda s: got.append(1))))  # fmt: skip
        subs: list = []
        late.start()
        assert out.wait_for_subscribers(mine, 10.0) == len(mine)  # each loop of the shard, once its owner subscribed
        assert got == [0]  # it waited for the subscription, declared 0.3 s on
        for lid in mine:
            out.put({"loop_id": lid, "seq": 0, "t0_s": 0.0, "ts_s": 1.0, "op": [1.0, 2.0], "pv": [0.5, 1.0]})
        wait_until(lambda: len(got) == 1 + len(mine), 5, "every loop's first batch")
        stop = threading.Event()
        threading.Timer(0.2, stop.set).start()
        t0 = time.monotonic()
        assert out.wait_for_subscribers(others, 30.0, stop) == 0  # nobody owns the other shards: a stop ends the wait
        assert time.monotonic() - t0 < 5.0
        assert out.wait_for_subscribers(mine + others, 0.3) == len(mine)
        subs[0].undeclare()
        out.close()
