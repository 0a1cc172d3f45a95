"""``stiction bridge opcua``: a plant's loops from its OPC UA server into the Zenoh key space.

Reads the loop file (which nodes are each loop's OP, PV, SP, MV and mode), subscribes to every
node, samples them on the loop file's grid with the server's source timestamps and publishes
``SampleBatch`` on ``{prefix}/loop/{id}/samples``.  Bad values are dropped and counted; a loop
whose node is missing is named in the health message (``{prefix}/bridge/{id}/health``) and the
others go on; after a server restart it reconnects by itself.  One status line every 10 s.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import socket
import sys
import time
from pathlib import Path

from stiction import zenoh_config
from stiction.commands.sim import DEFAULT_ENDPOINT, run_until_signal
from stiction.schemas import keys
from stiction.schemas.errors import InputError
from stiction.status import Every, bridge_line

log = logging.getLogger(__name__)
PASSWORD_ENV = "STICTION_OPCUA_PASSWORD"


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="source", required=True, metavar="SOURCE")
    o = sub.add_parser("opcua", help="an OPC UA server (asyncua client)", description=__doc__.replace("``", ""))
    o.add_argument("--loop-file", type=Path, required=True, help="TOML or YAML: loop id -> op/pv/sp/mv/mode nodes")
    o.add_argument("--endpoint", help="opc.tcp://HOST:PORT (default: the loop file's [server] endpoint)")
    o.add_argument(
        "--security", help="Policy,Mode,certificate,private_key e.g. Basic256Sha256,SignAndEncrypt,c.der,k.pem"
    )
    o.add_argument("--user", help="user name (the password comes from the environment, never a flag)")
    o.add_argument(
        "--password-env", default=None, help=f"environment variable holding the password (default {PASSWORD_ENV})"
    )
    o.add_argument(
        "--application-uri",
        default="urn:stiction:bridge",
        help="this client's application URI; with --security it must match the certificate (default %(default)s)",
    )
    o.add_argument("--bridge-id", help="unique per bridge (default: host-pid)")
    o.add_argument("--status-every", type=float, default=10.0, help="seconds between status lines (0: none)")
    o.add_argument(
        "--rate",
        type=float,
        help="messages per second per loop (default: one a sample time, each sample as it settles); 0.2: five "
        "seconds of a loop's samples a message, the loops spread over them (an agent's cost is per message)",
    )
    zenoh_config.add_arguments(o)
    zenoh_config.add_publisher_arguments(o)


def settings_from(args: argparse.Namespace, loop_file):
    from stiction.bridge.opcua import BridgeSettings

    server = loop_file.server
    endpoint = args.endpoint or (server.endpoint if server else None)
    if not endpoint:
        raise InputError("no OPC UA endpoint: give --endpoint or [server] endpoint in the loop file")
    if not endpoint.startswith("opc.tcp://"):
        raise InputError(f"--endpoint {endpoint!r}: expected opc.tcp://HOST:PORT")
    user = args.user or (server.user if server else None)
    env = args.password_env or (server.password_env if server and server.password_env else PASSWORD_ENV)
    password = os.environ.get(env)
    if user and password is None:
        raise InputError(f"user {user!r} given but no password in the environment variable {env}")
    bridge_id = args.bridge_id or f"{socket.gethostname()}-{os.getpid()}".replace(".", "-")
    try:
        keys.check_id(bridge_id, "bridge id")
    except ValueError as e:
        raise InputError(str(e)) from None
    security = args.security or (server.security if server else None)
    if security:
        parts = security.split(",")
        if len(parts) != 4 or parts[1] not in ("Sign", "SignAndEncrypt"):
            raise InputError(
                f"--security {security!r}: expected Policy,Mode,certificate,private_key with Mode Sign or "
                "SignAndEncrypt, e.g. Basic256Sha256,SignAndEncrypt,cert.der,key.pem"
            )
        for f in parts[2:]:
            if not Path(f).is_file():
                raise InputError(f"--security: {f}: no such file")
    rate = args.rate
    if rate is not None and not (math.isfinite(rate) and rate > 0):
        raise InputError(f"--rate {rate:g}: messages per second per loop, a positive number (0.2: one every 5 s)")
    return BridgeSettings(
        bridge_id, endpoint, security=security, user=user, password=password, application_uri=args.application_uri,
        batch_s=None if rate is None else 1.0 / rate,
    )  # fmt: skip


class Status:
    """The bridge's status line: its health, with the publishing rate since the last line."""

    def __init__(self, every_s: float):
        self.every = Every(every_s)
        self.last_t, self.last_samples = time.monotonic(), 0

    def maybe(self, health) -> None:
        if not self.every():
            return
        now = time.monotonic()
        rate = (health.samples_published - self.last_samples) / max(now - self.last_t, 1e-9)
        self.last_t, self.last_samples = now, health.samples_published
        print(bridge_line(health, rate), flush=True)


def run(args: argparse.Namespace) -> int:
    import zenoh

    from stiction.bridge.loopfile import load
    from stiction.bridge.opcua import OpcuaBridge

    loop_file = load(args.loop_file)
    settings = settings_from(args, loop_file)
    if not args.listen and not args.connect and args.config is None:
        args.listen = [DEFAULT_ENDPOINT]
    if args.verbose < 2:
        logging.getLogger("asyncua").setLevel(logging.CRITICAL)  # its own reconnect chatter; ours says it once
    status = Status(args.status_every)
    with zenoh_config.open_from_args(args) as session:
        put = {"encoding": zenoh.Encoding.APPLICATION_JSON, "congestion_control": zenoh.CongestionControl.BLOCK}
        out = zenoh_config.publisher(args, session)

        def on_health(health) -> None:
            session.put(keys.bridge_health(args.prefix, settings.bridge_id), health.model_dump_json().encode(), **put)
            status.maybe(health)

        bridge = OpcuaBridge(loop_file, settings, out.put, on_health)
        batched = f", {bridge.message_every_s:g} s a message" if settings.batch_s else ""
        print(
            f"bridge {settings.bridge_id}: {len(loop_file.loops)} loops from {settings.endpoint} "
            f"every {loop_file.sample_time_s:g} s to {zenoh_config.samples_keys(args)}{batched}",
            flush=True,
        )

        run_until_signal(bridge.run)
    print(f"bridge {settings.bridge_id} stopped: {bridge.health().model_dump_json()}", file=sys.stderr)
    return 0
