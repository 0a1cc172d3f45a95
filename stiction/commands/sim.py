"""``stiction sim``: stream many simulated, noisy loops over Zenoh until stopped."""

from __future__ import annotations

import argparse
import logging
import signal
import threading
import time

from stiction import zenoh_config
from stiction.schemas.errors import InputError
from stiction.status import Every

log = logging.getLogger(__name__)
DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--loops", type=int, default=100)
    p.add_argument("--rate", type=float, default=1.0, help="messages per second per loop (default 1)")
    p.add_argument("--speed", type=float, default=1.0, help="simulated seconds per second (default 1: real time)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--duration-s", type=float, help="stop after this much simulated time")
    p.add_argument("--status-every", type=float, default=10.0, help="seconds between status lines (0: none)")
    zenoh_config.add_arguments(p)
    zenoh_config.add_publisher_arguments(p)


def stop_on_signals() -> threading.Event:
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    return stop


def run_until_signal(work):
    """``asyncio.run(work(stop))`` with ``stop`` (an ``asyncio.Event``) set on SIGINT or SIGTERM."""
    import asyncio

    async def main():
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        return await work(stop)

    return asyncio.run(main())


def run(args: argparse.Namespace) -> int:

    from stiction.sim.publisher import PublisherSettings
    from stiction.sim.publisher import run as publish

    if args.loops < 1 or args.rate <= 0 or args.speed <= 0:
        raise InputError("--loops, --rate and --speed must be positive")
    if not args.listen and not args.connect and args.config is None:
        args.listen = [DEFAULT_ENDPOINT]
    settings = PublisherSettings(
        prefix=args.prefix,
        loops=args.loops,
        seed=args.seed,
        speed=args.speed,
        rate_hz=args.rate,
        duration_s=args.duration_s,
        sharded=not args.unsharded,
        history_samples=args.history,
    )
    log.info("settings: %s", settings)
    stop = stop_on_signals()
    every, mark = Every(args.status_every), [time.monotonic(), 0]

    def status(published: int) -> None:
        if every():
            now = time.monotonic()
            rate = (published - mark[1]) * args.loops / (now - mark[0])
            mark[:] = [now, published]
            print(
                f"sim: {args.loops} loops, {rate:.0f} samples/s ({args.speed:g}x real time), "
                f"{published} samples per loop so far",
                flush=True,
            )

    with zenoh_config.open_from_args(args) as session:
        print(
            f"sim: {args.loops} loops on {zenoh_config.samples_keys(args)} at {args.speed:g}x real time, "
            f"{', '.join(args.listen or args.connect or [str(args.config)])}; "
            f"a status line every {args.status_every:g} s",
            flush=True,
        )
        published = publish(settings, session, stop, on_tick=status)
    log.info("published %d samples per loop", published)
    return 0
