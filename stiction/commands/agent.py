"""``stiction agent``: quantify the loops streamed on Zenoh and publish their reports; stop with SIGINT/SIGTERM."""

from __future__ import annotations

import argparse
import logging
import os
import socket
from pathlib import Path

from stiction import zenoh_config
from stiction.bridge import zenoh_session
from stiction.commands.sim import DEFAULT_ENDPOINT, stop_on_signals
from stiction.heap import release_library_pages
from stiction.schemas import keys
from stiction.schemas.errors import InputError
from stiction.status import Every, agent_line

log = logging.getLogger(__name__)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--models", type=Path, help="directory with the ONNX models and their cards")
    p.add_argument("--agent-id", default=None, help="unique per agent (default: host-pid)")
    p.add_argument("--window", type=int, default=1000, help="samples per loop window (default 1000)")
    p.add_argument(
        "--first-window",
        type=int,
        default=200,
        help="a new loop's first report once it holds this many samples, flagged partial (default 200)",
    )
    p.add_argument("--report-every", type=int, default=60, help="new samples between a loop's reports (default 60)")
    p.add_argument(
        "--estimate-every",
        type=int,
        default=5,
        help="reports of a loop still called sticky between fresh friction readings; the reports between carry "
        "the last one, with estimate_t_end_s (default 5; 1: every report). Verdicts are read from every window",
    )
    p.add_argument(
        "--size-every",
        type=float,
        default=60.0,
        metavar="MINUTES",
        help="a loop called sticky whose process is unknown has it identified and S and J read under it, a loop "
        "whose stream carries the valve position (mv) has its stem checked against OP, and a sticky level loop whose "
        "slips PV's noise hides has its valve fitted to its window, in the background on workers of lowered "
        "priority, once in this many minutes (default 60; 0: never)",
    )
    p.add_argument(
        "--size-workers",
        type=int,
        default=1,
        metavar="N",
        help="worker processes for those sizings (default 1): each sizes about 1,000 loops an hour on a core of its "
        "own; more sticky loops of unknown process than that are sized less often than --size-every",
    )
    p.add_argument("--status-every", type=float, default=10.0, help="seconds between status lines (0: none)")
    p.add_argument("--rerun", metavar="MODE", help="show the loops in rerun: save:PATH, spawn or serve (web viewer)")
    zenoh_config.add_arguments(p)


def open_sink(mode: str | None):
    """The rerun sink for ``--rerun MODE``, or None; a bad mode is a one-line error."""
    if not mode:
        return None
    if not (mode in ("spawn", "serve") or (mode.startswith("save:") and len(mode) > 5)):
        raise InputError(f"--rerun {mode!r}: expected save:PATH, spawn or serve")
    try:
        from stiction.agent.viewer import RerunSink
    except ImportError:
        raise InputError("--rerun needs the viewer extra: pip install -e '.[viewer]'") from None
    sink = RerunSink(mode)
    if mode == "serve":
        print(f"rerun web viewer: {sink.web_url()}", flush=True)
    return sink


def run(args: argparse.Namespace) -> int:

    from stiction.agent.core import CoreSettings
    from stiction.agent.service import AgentService, AgentSettings

    if args.size_every < 0:
        raise InputError(f"--size-every {args.size_every:g}: minutes, at least 0 (0: never)")
    if args.size_workers < 1:
        raise InputError(f"--size-workers {args.size_workers}: at least 1 worker process")
    if args.window < 100 or args.first_window < 100 or args.report_every < 1 or args.estimate_every < 1:
        raise InputError(
            "--window and --first-window must be at least 100 samples, --report-every and --estimate-every at least 1"
        )
    if not args.listen and not args.connect and args.config is None:
        args.connect = [DEFAULT_ENDPOINT]
        args.listen = [zenoh_session.free_loopback_endpoint()]
    agent_id = args.agent_id or f"{socket.gethostname()}-{os.getpid()}".replace(".", "-")
    core = CoreSettings(
        prefix=args.prefix,
        window_samples=args.window,
        report_every_samples=args.report_every,
        first_report_samples=args.first_window,
        estimate_every=args.estimate_every,
    )
    settings = AgentSettings(
        agent_id=agent_id,
        core=core,
        size_every_s=60.0 * args.size_every,
        size_workers=args.size_workers,
        models_dir=args.models,
    )
    log.info("settings: %s", settings)
    stop = stop_on_signals()
    sink = open_sink(args.rerun)
    with zenoh_config.open_from_args(args) as session:
        service = AgentService(settings, session, sink=sink)
        every = Every(args.status_every)
        service.on_health = lambda h: print(agent_line(h), flush=True) if every() else None
        print(
            f"agent {agent_id}: listening on {keys.all_samples(args.prefix)} and its shards' "
            f"{keys.shard_samples(args.prefix, '{shard}')}; a new loop's first report after "
            f"{args.first_window} samples (partial), then every {args.report_every} samples (friction read afresh "
            f"every {args.estimate_every} reports of a sticky loop); "
            f"a status line every {args.status_every:g} s",
            flush=True,
        )
        service.start()
        released = release_library_pages()  # after the warm-up: the kernels compiled, the compiler's code is idle
        log.info("numba's compiler: %.0f MB of its code handed back to the page cache", released / 2**20)
        try:
            service.run(stop)
        finally:
            service.close()
            if sink is not None:
                sink.close()
    log.info("agent %s stopped: %s", agent_id, service.health().model_dump_json())
    return 0
