"""The command line's Zenoh flags: every command gets the same ones (``add_arguments``), and the
publishers theirs; the session they open is ``bridge.zenoh_session``'s (peer mode, multicast
scouting off, listening on loopback unless told otherwise)."""

from __future__ import annotations

import argparse
from pathlib import Path

from stiction.bridge.zenoh_session import build, open_session
from stiction.schemas import keys
from stiction.schemas.errors import InputError


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
    from stiction.bridge.publish import SamplePublisher

    if args.history < 0:
        raise InputError("--history must be 0 or more samples")
    return SamplePublisher(session, args.prefix, sharded=not args.unsharded, keep_samples=args.history)


def from_args(args: argparse.Namespace):
    try:
        keys.check_prefix(args.prefix)
    except ValueError as e:
        raise InputError(str(e)) from None
    return build(args.listen, args.connect, args.config)


def open_from_args(args: argparse.Namespace):
    given = {"listen": args.listen, "connect": args.connect, "config": args.config}
    return open_session(from_args(args), ", ".join(f"{k} {v}" for k, v in given.items() if v))
