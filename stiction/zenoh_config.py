"""Zenoh configuration for every process: a file, then flags, then fixed overrides, in one helper.

Peer mode; multicast scouting off (it reaches beyond loopback); listen on
loopback unless told otherwise.  ``add_arguments`` gives every command the same flags.
"""

from __future__ import annotations

import argparse
import json
import socket
from pathlib import Path

from schemas import keys
from schemas.errors import InputError


def add_arguments(p: argparse.ArgumentParser, listen_default: bool = True) -> None:
    p.add_argument("--prefix", default=keys.DEFAULT_PREFIX, help="key space prefix (default %(default)s)")
    p.add_argument("--listen", action="append", metavar="ENDPOINT", help="e.g. tcp/127.0.0.1:7447 (repeatable)")
    p.add_argument("--connect", action="append", metavar="ENDPOINT", help="e.g. tcp/127.0.0.1:7447 (repeatable)")
    p.add_argument("--config", type=Path, help="a full Zenoh JSON5 configuration file; flags override it")


def add_publisher_arguments(p: argparse.ArgumentParser) -> None:
    """The sample publishers' flags (``stiction sim``, ``replay``, ``bridge opcua``)."""
    p.add_argument(
        "--unsharded",
        action="store_true",
        help="put samples on {prefix}/loop/{id}/samples, which every agent receives (default: on the loop's "
        "shard key {prefix}/loop/{id}/samples/{shard}, received by the shard's owner only)",
    )
    p.add_argument(
        "--history",
        type=int,
        default=1000,
        metavar="SAMPLES",
        help="recent samples of each loop kept to answer an agent that takes its shard over (default 1000; 0: none)",
    )


def samples_keys(args) -> str:
    """Where the publisher flags put samples, for a start-up line."""
    return keys.all_samples(args.prefix) if args.unsharded else keys.shard_samples(args.prefix, "{shard}")


def publisher(args, session):
    """The ``SamplePublisher`` the publisher flags ask for."""
    from bridge.publish import SamplePublisher

    if args.history < 0:
        raise InputError("--history must be 0 or more samples")
    return SamplePublisher(session, args.prefix, sharded=not args.unsharded, keep_samples=args.history)


def free_loopback_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on now (for Zenoh, or an OPC UA server in tests)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def free_loopback_endpoint() -> str:
    return f"tcp/127.0.0.1:{free_loopback_port()}"


def build(listen: list[str] | None = None, connect: list[str] | None = None, config_file: Path | None = None):
    """A ``zenoh.Config``; with neither endpoint given, listen on a free loopback port."""
    import zenoh

    if config_file is not None:
        try:
            cfg = zenoh.Config.from_file(str(config_file))
        except Exception as e:  # zenoh raises its own error types for unreadable files
            raise InputError(f"{config_file}: not a Zenoh configuration ({e})") from None
    else:
        cfg = zenoh.Config()
        cfg.insert_json5("mode", '"peer"')
        cfg.insert_json5("scouting/multicast/enabled", "false")
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


def from_args(args: argparse.Namespace):
    try:
        keys.check_prefix(args.prefix)
    except ValueError as e:
        raise InputError(str(e)) from None
    return build(args.listen, args.connect, args.config)


def open_session(cfg, endpoints: str = ""):
    """``zenoh.open`` with its errors (bad endpoint, port in use, ...) as one-line input errors."""
    import zenoh

    try:
        return zenoh.open(cfg)
    except zenoh.ZError as e:
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        where = f" ({endpoints})" if endpoints else ""
        raise InputError(f"cannot open a Zenoh session{where}: {first.split(' at /')[0]}") from None


def open_from_args(args: argparse.Namespace):
    given = {"listen": args.listen, "connect": args.connect, "config": args.config}
    return open_session(from_args(args), ", ".join(f"{k} {v}" for k, v in given.items() if v))
