"""Who owns which loops: rendezvous hashing of shards over the agents alive, the same answer in
every agent from the same membership (pure; ``agent.core`` keeps the roles it gives)."""

from __future__ import annotations

import hashlib
from collections import Counter

from stiction.schemas import keys


def rank(agent_id: str, loop_id: str) -> int:
    digest = hashlib.blake2b(f"{agent_id}\0{loop_id}".encode(), digest_size=8).digest()
    return int.from_bytes(digest, "big")


def assign(agents: tuple[str, ...], shards: int = keys.SHARDS) -> list[str]:
    """The owner of every shard: rendezvous hashing, highest (agent, shard) rank first, each agent
    taking its even share (``shards // agents``, and one more for as many agents as the remainder
    needs).  Every agent computes the same from the same membership."""
    base, extra = divmod(shards, len(agents))
    pairs = sorted(((rank(a, f"shard/{k}"), a, k) for a in agents for k in range(shards)), reverse=True)
    owner: list[str | None] = [None] * shards
    load: Counter[str] = Counter()
    for _, a, k in pairs:
        if owner[k] is None and load[a] < base:
            owner[k], load[a] = a, load[a] + 1
    for _, a, k in pairs:  # the remainder: one more shard each for the agents that rank highest for it
        if owner[k] is None and load[a] == base and extra > 0:
            owner[k], load[a], extra = a, load[a] + 1, extra - 1
    return owner  # type: ignore[return-value]
