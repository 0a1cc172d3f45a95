"""The agent's sample subscriptions are channels its worker drains: a hand-over of shards loses no sample.

A fake session stands in for Zenoh: its subscriptions are queues, and while the agent declares the
subscriptions of the shards it keeps, a sample still reaches the subscription to every shard that is
about to go (as one in flight would).  The agent must read it before it undeclares that subscription:
a channel cannot be read once undeclared."""

from collections import deque

from stiction.agent.core import CoreSettings
from stiction.agent.service import AgentService, AgentSettings
from stiction.schemas import keys

PREFIX = "test/channels"


class _Payload:
    def __init__(self, body: bytes):
        self._body = body

    def to_bytes(self) -> bytes:
        return self._body


class _Sample:
    def __init__(self, key: str, body: bytes):
        self.key_expr, self.payload, self.encoding = key, _Payload(body), "application/json"


class _Subscriber:
    def __init__(self, expr: str):
        self.expr, self.queue, self.undeclared = expr, deque(), False

    def try_recv(self):
        if self.undeclared:
            raise RuntimeError("Undeclared subscriber")  # as zenoh's channels do
        return self.queue.popleft() if self.queue else None

    def undeclare(self):
        self.undeclared = True


class _Session:
    """Subscriptions as queues; declaring a shard's subscription delivers ``in_flight`` to the
    subscription to every shard, which is about to go."""

    def __init__(self):
        self.subscribers: list[_Subscriber] = []
        self.in_flight: list[_Sample] = []

    def declare_subscriber(self, expr, handler=None):
        sub = _Subscriber(str(expr))
        if expr != keys.shard_samples(PREFIX, "*"):
            every = [s for s in self.subscribers if s.expr == keys.shard_samples(PREFIX, "*") and not s.undeclared]
            for s in every:
                s.queue.extend(self.in_flight)
            self.in_flight = []
        self.subscribers.append(sub)
        return sub


def _loop_in_shard(shards: set[int]) -> str:
    return next(f"L{i}" for i in range(10_000) if keys.shard_of(f"L{i}") in shards)


def test_a_sample_reaching_a_subscription_that_is_about_to_go_is_not_lost():
    session = _Session()
    settings = AgentSettings("agent-a", CoreSettings(prefix=PREFIX), size_every_s=0)
    agent = AgentService(settings, session, quantifier=object())
    agent._sync_shards()  # alone: one subscription to every shard
    assert [s.expr for s in session.subscribers] == [keys.shard_samples(PREFIX, "*")]

    agent.core.set_agents({"agent-b"})  # a second agent: half the shards go
    kept = agent.core.owned_shards()
    assert 0 < len(kept) < keys.SHARDS
    loop_id = _loop_in_shard(kept)
    key = keys.sharded_samples(PREFIX, loop_id)
    session.in_flight = [_Sample(key, b'{"loop_id": "%s"}' % loop_id.encode())]
    agent._sync_shards()

    assert session.subscribers[0].undeclared  # the subscription to every shard went
    assert sorted(s.expr for s in session.subscribers if not s.undeclared) == sorted(
        keys.shard_samples(PREFIX, k) for k in kept
    )
    assert [m[0] for m in agent._inbox] == [key]  # and what reached it meanwhile was read first
