"""The Zenoh key space (spec/interfaces.md): every key expression is built here and nowhere else."""

from __future__ import annotations

import re

DEFAULT_PREFIX = "stiction/demo"
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
    return rest[0] if len(rest) == 2 else None


def agent_id_of(prefix: str, key: str) -> str | None:
    head = f"{prefix}/agent/"
    if not key.startswith(head):
        return None
    rest = key[len(head) :]
    return rest if "/" not in rest else None
