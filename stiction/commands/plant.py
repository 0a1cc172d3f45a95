"""``stiction plant``: simulated loops served over OPC UA, as a plant's control system would serve them.

Writes the loop file a bridge needs (``--loop-file``) once the server is up, then a sample of
every loop each sample time (1 s of the thesis's loop every 1/--speed s of wall clock).
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

from stiction.commands.sim import run_until_signal
from stiction.schemas.errors import InputError
from stiction.status import Every

log = logging.getLogger(__name__)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--loops", type=int, default=100)
    p.add_argument("--endpoint", default="opc.tcp://127.0.0.1:4840", help="where the server listens")
    p.add_argument("--advertise", help="the endpoint clients use, written into the loop file (default --endpoint)")
    p.add_argument("--loop-file", type=Path, help="write the bridge's loop file here once the server is up")
    p.add_argument("--speed", type=float, default=1.0, help="simulated seconds per wall-clock second (default 1)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--certificate", type=Path, help="server certificate (DER or PEM): serve only Basic256Sha256")
    p.add_argument("--private-key", type=Path, help="the certificate's private key (PEM)")
    p.add_argument(
        "--fault-every", type=int, default=0, metavar="N", help="a Bad status on the first loop's PV every N samples"
    )
    p.add_argument("--status-every", type=float, default=10.0, help="seconds between status lines (0: none)")


def run(args: argparse.Namespace) -> int:
    from stiction.bridge.loopfile import dumps
    from stiction.sim.opcua_plant import PlantSettings, serve

    if args.loops < 1 or args.speed <= 0:
        raise InputError("--loops and --speed must be positive")
    if not args.endpoint.startswith("opc.tcp://"):
        raise InputError(f"--endpoint {args.endpoint!r}: expected opc.tcp://HOST:PORT")
    if args.loop_file is not None and not args.loop_file.parent.is_dir():
        raise InputError(f"--loop-file {args.loop_file}: no such directory {args.loop_file.parent}")
    if args.verbose < 2:
        logging.getLogger("asyncua").setLevel(logging.CRITICAL)
    if (args.certificate is None) != (args.private_key is None):
        raise InputError("--certificate and --private-key go together")
    for f in (args.certificate, args.private_key):
        if f is not None and not f.is_file():
            raise InputError(f"{f}: no such file")
    settings = PlantSettings(
        args.endpoint,
        args.loops,
        args.seed,
        args.speed,
        advertised_endpoint=args.advertise,
        certificate=str(args.certificate) if args.certificate else None,
        private_key=str(args.private_key) if args.private_key else None,
        fault_every=max(args.fault_every, 0),
    )

    def ready(loop_file) -> None:
        if args.loop_file is not None:
            tmp = args.loop_file.with_suffix(args.loop_file.suffix + ".tmp")
            tmp.write_text(dumps(loop_file))
            tmp.replace(args.loop_file)  # a bridge waiting for the file never reads half of it
        print(
            f"plant: {args.loops} loops on {args.endpoint}"
            + (f", loop file {args.loop_file}" if args.loop_file else ""),
            flush=True,
        )

    every = Every(args.status_every)

    def status(c: dict) -> None:
        if every():
            print(
                f"plant: {args.loops} loops, {c['written']} samples written per loop, "
                f"{c['skipped']} skipped (fell behind), last write pass {c['pass_s']:.2f} s",
                flush=True,
            )

    async def work(stop) -> int:
        try:
            return await serve(settings, stop, ready, status)
        except OSError as e:
            raise InputError(f"cannot serve on {args.endpoint}: {e.strerror or e}") from None

    written = run_until_signal(work)
    log.info("wrote %d samples per loop", written)
    return 0
