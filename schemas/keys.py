"""The Zenoh key space (spec/interfaces.md): every key expression is built here and nowhere else."""

from __future__ import annotations

import functools
import hashlib
import re

DEFAULT_PREFIX = "stiction/demo"
SHARDS = 32
"""Shards of the sharded sample keys.  A loop's shard is a hash of its id; agents own shards (not
single loops), as evenly as their number allows (``agent.ownership.assign``), and subscribe to their
shards' keys only, so that N agents each receive about 1/N of the samples.  Few on purpose: Zenoh
matches every message against each subscription of the receiving session (about 0.2 us each here:
256 subscriptions cost an agent 56 us a message, one costs 6 us); 32 shards of 10,000 loops hold
about 310 loops each, so two agents split them 50/50 within a few percent.  At most 32 agents per
key prefix: split a larger plant into areas, one prefix each."""
_ID = re.compile(r"^[A-Za-z0-9_.:=+-][A-Za-z0-9_.:=+#-]{0,199}$")


def check_id(name: str, what: str = "loop id") -> str:
    """Loop and agent ids are one key chunk: no '/', no wildcards, no '$' or '?'."""
    if not _ID.match(name):
        raise ValueError(f"{what} {name!r}: use letters, digits and _ . : = + - # (at most 200, no '/' or '*')")
    return name


def check_prefix(prefix: str) -> str:
    if not prefix or prefix.startswith("/") or prefix.endswith("/") or any(c in prefix for c in "*$?#"):
        raise ValueError(f"prefix {prefix!r}: one or more key chunks like 'stiction/demo', without wildcards")
    return prefix


def samples(prefix: str, loop_id: str) -> str:
    return f"{prefix}/loop/{check_id(loop_id)}/samples"


@functools.lru_cache(maxsize=1 << 17)  # asked for every message an agent receives
def shard_of(loop_id: str) -> int:
    return int.from_bytes(hashlib.blake2b(loop_id.encode(), digest_size=4).digest(), "big") % SHARDS


def sharded_samples(prefix: str, loop_id: str) -> str:
    """``{prefix}/loop/{id}/samples/{shard}``: the samples of one loop, under its shard (the publishers of
    this project put here; ``{prefix}/loop/*/samples/**`` matches both forms)."""
    return f"{samples(prefix, loop_id)}/{shard_of(loop_id)}"


def shard_samples(prefix: str, shard: int | str) -> str:
    """Every loop's samples in one shard (``"*"``: in every shard): what an agent owning it subscribes to."""
    return f"{prefix}/loop/*/samples/{shard}"


def samples_any(prefix: str) -> str:
    """Every loop's samples, sharded or not (a publisher's history queryable answers on it)."""
    return f"{prefix}/loop/*/samples/**"


def is_sharded(key: str) -> bool:
    return not key.endswith("/samples")


def truth(prefix: str, loop_id: str) -> str:
    return f"{prefix}/loop/{check_id(loop_id)}/truth"


def report(prefix: str, loop_id: str) -> str:
    return f"{prefix}/loop/{check_id(loop_id)}/report"


def agent_token(prefix: str, agent_id: str) -> str:
    return f"{prefix}/agent/{check_id(agent_id, 'agent id')}"


def agent_health(prefix: str, agent_id: str) -> str:
    return f"{prefix}/agent/{check_id(agent_id, 'agent id')}/health"


def bridge_health(prefix: str, bridge_id: str) -> str:
    return f"{prefix}/bridge/{check_id(bridge_id, 'bridge id')}/health"


def all_samples(prefix: str) -> str:
    return f"{prefix}/loop/*/samples"


def all_truths(prefix: str) -> str:
    return f"{prefix}/loop/*/truth"


def all_reports(prefix: str) -> str:
    return f"{prefix}/loop/*/report"


def all_agents(prefix: str) -> str:
    return f"{prefix}/agent/*"


def loop_id_of(prefix: str, key: str) -> str | None:
    """The loop id in ``{prefix}/loop/{id}/...``, or None if the key is not of that form."""
    head = f"{prefix}/loop/"
    if not key.startswith(head):
        return None
    rest = key[len(head) :].split("/")
    if len(rest) == 3 and rest[1] == "samples" and rest[2].isdigit():  # a sharded samples key
        return rest[0]
    return rest[0] if len(rest) == 2 else None


def agent_id_of(prefix: str, key: str) -> str | None:
    head = f"{prefix}/agent/"
    if not key.startswith(head):
        return None
    rest = key[len(head) :]
    return rest if "/" not in rest else None
