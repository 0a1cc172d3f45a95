"""``stiction replay``: historian exports streamed into the Zenoh key space at --speed times real time.

Each export (CSV or Parquet; a folder is every export in it) becomes one loop, its id from the
file name, all loops starting together; ``SampleBatch`` on each loop's shard key (``bridge.publish``)
with the file's own times, so an agent, the viewer and any dashboard run on the plant's recorded data.
A file that cannot be read is named on one line and the others are replayed.
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from pathlib import Path

from stiction import zenoh_config
from stiction.commands.exports import add_pv_span, report_error
from stiction.commands.sim import DEFAULT_ENDPOINT, stop_on_signals
from stiction.schemas import keys
from stiction.schemas.errors import InputError

FIELDS = ("op", "pv", "t", "sp", "mv", "mode")
WAIT_S = 5.0


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("paths", nargs="+", type=Path, metavar="PATH", help="historian exports or folders of them")
    p.add_argument("--speed", type=float, default=1.0, help="recorded seconds per wall-clock second (default 1)")
    p.add_argument("--rate", type=float, default=1.0, help="messages per second per loop (default 1)")
    p.add_argument("--ts", type=float, help="sample time [s] for files without a time column (default 1)")
    p.add_argument("--process", choices=["level"], help="declare every replayed loop the canonical level loop")
    add_pv_span(p)
    p.add_argument(
        "--wait",
        type=float,
        default=WAIT_S,
        metavar="S",
        help=f"seconds to wait, before the first batch, for every loop to have a subscriber (an agent, a "
        f"dashboard): a replay started beside an agent that is still connecting lost its first batches; "
        f"0: start at once (default {WAIT_S:g})",
    )
    p.add_argument("--status-every", type=float, default=10.0, help="seconds between status lines (0: none)")
    zenoh_config.add_arguments(p)
    zenoh_config.add_publisher_arguments(p)


def read_tracks(paths, ts_s, process, command: str = "replay", pv_span=None) -> tuple[list, list[str]]:
    """One track per readable export (``bridge.replay.read_tracks``); each unreadable one named on
    one line (and returned)."""
    from stiction.bridge.replay import read_tracks as read
    from stiction.quantify.window import MIN_SAMPLES

    tracks, errors = read(paths, ts_s, process, MIN_SAMPLES, pv_span)
    return tracks, [report_error(command, path, e) for path, e in errors]


def publish(schedule, out, stop: threading.Event, rate_hz: float, status_every_s: float = 0.0):
    """Play ``schedule`` into the key space (``out``: a ``bridge.publish.SamplePublisher``) until it is
    done or ``stop`` is set."""
    started = last_status = time.monotonic()
    last_samples = 0
    while not stop.is_set():
        now = time.monotonic()
        for batch in schedule.due(now - started):
            out.put(batch)
        if schedule.done:
            break
        if status_every_s > 0 and now - last_status >= status_every_s:
            rate = (schedule.samples_published - last_samples) / (now - last_status)
            last_status, last_samples = now, schedule.samples_published
            share = min(1.0, (now - started) / max(schedule.duration_s, 1e-9))
            print(
                f"replay: {len(schedule.tracks)} loops, {share:.0%} played, {rate:.0f} samples/s, "
                f"{schedule.samples_published} samples sent",
                flush=True,
            )
        step = schedule.step_s or 1.0 / rate_hz  # each group of loops' turn (bridge.replay.Schedule)
        stop.wait(max(0.0, started + (int((now - started) / step) + 1) * step - time.monotonic()))
    return schedule.samples_published


def run(args: argparse.Namespace) -> int:
    from stiction.bridge.historian import check_span
    from stiction.bridge.publish import stagger_groups
    from stiction.bridge.replay import Schedule

    if args.speed <= 0 or args.rate <= 0:
        raise InputError("--speed and --rate must be positive")
    if not args.wait >= 0:
        raise InputError("--wait must be 0 or more seconds")
    span = check_span(args.pv_span)  # before any file: a bad range is the command's error
    tracks, failed = read_tracks(args.paths, args.ts, args.process, pv_span=span)
    if not tracks:
        raise InputError(f"nothing to replay: {len(failed)} file(s), none readable")
    for t in tracks:
        keys.check_id(t.loop_id)
        for note in t.notes:  # a gap in an export's time: only the stretch after it is replayed
            print(f"replay: {t.source}: {note}", file=sys.stderr)
    if not args.listen and not args.connect and args.config is None:
        args.listen = [DEFAULT_ENDPOINT]
    groups = len(stagger_groups(len(tracks), 1.0 / args.rate))
    schedule = Schedule(tracks, args.speed, args.rate, groups)
    print(
        f"replay: {len(tracks)} loops to {zenoh_config.samples_keys(args)} at {args.speed:g}x, "
        f"{schedule.duration_s:.0f} s of wall clock" + (f"; {len(failed)} file(s) skipped" if failed else ""),
        flush=True,
    )
    stop = stop_on_signals()
    with zenoh_config.open_from_args(args) as session:
        out = zenoh_config.publisher(args, session)
        try:
            if args.wait > 0:
                heard = out.wait_for_subscribers([t.loop_id for t in tracks], args.wait, stop)
                if heard < len(tracks):
                    print(f"replay: {len(tracks) - heard} of {len(tracks)} loops have no subscriber after "
                          f"{args.wait:g} s; replaying anyway", file=sys.stderr)  # fmt: skip
            sent = publish(schedule, out, stop, args.rate, args.status_every)
        finally:
            out.close()
    print(f"replay: done, {sent} samples of {len(tracks)} loops sent", file=sys.stderr)
    return 1 if failed else 0
