"""Zenoh sessions for every process: peer mode on loopback, explicit endpoints, multicast scouting off.

``build`` makes the configuration (a file, then endpoints, then fixed overrides), ``open_session``
opens it with Zenoh's errors as one-line input errors; the command line's flags for them are in
``stiction.zenoh_config``.
"""

from __future__ import annotations

import json
import os
import socket
from pathlib import Path

from stiction.schemas.errors import InputError

SHARED_MEMORY = False
"""Zenoh's shared-memory transport, in the configuration made without a file.  On, every process that
sends a message over 3 kB (a publisher's history reply, a large batch) maps a pool of 16 MB in /dev/shm and
touches all of it: 16 MB of an agent's RSS at 10,000 loops (its smaps, 2026-11-26), for messages of a few
kB that loopback TCP carries as well; and a container's /dev/shm is 64 MB by default.  A configuration file
(``--config``) decides for itself."""


RUNTIME = "(rx: (handover: app), acc: (handover: app))"
"""Zenoh's runtimes for every process of ours, unless ``ZENOH_RUNTIME`` in the environment says otherwise: the
receiving and accepting tasks run on the application runtime's worker thread instead of three threads of their
own.  Every thread that allocates gets a malloc arena of its own, and the agent's 10,000 messages a second left
103 MB resident in the arenas of Zenoh's threads (its smaps, docs/scaling.md).  `stiction bench throughput
--loops 10000 --seconds 60 --json`, the agent's peak RSS, runs alternated in one hour: 479, 484, 484, 493,
498 MB with Zenoh's runtimes; 434, 436, 436, 448, 455 MB with this (everything on that one thread: 446, 457,
458); p99 0.28-0.32 s, 0 samples lost and 0.35-0.40 of a core either way.  Zenoh reads it when a process
opens its first session."""


def free_loopback_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on now (for Zenoh, or an OPC UA server in tests)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def free_loopback_endpoint() -> str:
    return f"tcp/127.0.0.1:{free_loopback_port()}"


def build(listen: list[str] | None = None, connect: list[str] | None = None, config_file: Path | None = None):
    """A ``zenoh.Config``; with neither endpoint given, listen on a free loopback port.  Sets Zenoh's runtimes
    (``RUNTIME``) for a process whose environment does not."""
    import zenoh

    os.environ.setdefault("ZENOH_RUNTIME", RUNTIME)

    if config_file is not None:
        try:
            cfg = zenoh.Config.from_file(str(config_file))
        except Exception as e:  # zenoh raises its own error types for unreadable files
            raise InputError(f"{config_file}: not a Zenoh configuration ({e})") from None
    else:
        cfg = zenoh.Config()
        cfg.insert_json5("mode", '"peer"')
        cfg.insert_json5("scouting/multicast/enabled", "false")
        cfg.insert_json5("transport/shared_memory/enabled", json.dumps(SHARED_MEMORY))
        if not listen and not connect:
            listen = [free_loopback_endpoint()]
    try:
        if listen:
            cfg.insert_json5("listen/endpoints", json.dumps(listen))
        if connect:
            cfg.insert_json5("connect/endpoints", json.dumps(connect))
    except Exception as e:
        raise InputError(f"bad Zenoh endpoint in {listen or connect}: {e}") from None
    return cfg


def open_session(cfg, endpoints: str = ""):
    """``zenoh.open`` with its errors (bad endpoint, port in use, ...) as one-line input errors; a
    ``ZENOH_RUNTIME`` Zenoh cannot read (it panics) is named as such."""
    import zenoh

    where = f" ({endpoints})" if endpoints else ""
    try:
        return zenoh.open(cfg)
    except zenoh.ZError as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise InputError(f"cannot open a Zenoh session{where}: {first.split(' at /')[0]}") from None
    except BaseException as e:  # Zenoh's Rust panics arrive as pyo3's PanicException, a BaseException
        if type(e).__name__ != "PanicException":
            raise
        runtime = os.environ.get("ZENOH_RUNTIME", "")
        said = str(e).strip().splitlines()[0][:200] if str(e).strip() else "a panic"
        if runtime != RUNTIME and runtime:
            raise InputError(f"cannot open a Zenoh session{where}: ZENOH_RUNTIME={runtime!r} is not a runtime "
                             f"setting Zenoh reads ({said})") from None  # fmt: skip
        raise InputError(f"cannot open a Zenoh session{where}: Zenoh failed ({said})") from None
