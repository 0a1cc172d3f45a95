"""``stiction plant``: simulated loops served by an OPC UA server, as a plant's control system serves them.

Each loop is a folder ``plant-00000``... with the variables OP, PV, SP, MV and MODE (1: auto), node
ids ``ns={ns};s={loop id}.OP``.  Sample ``k`` of every loop is written at wall-clock time
``t_k = k * sample_time_s`` (a grid of the Unix clock) with that time as its source timestamp,
so a bridge sampling on the same grid reads each sample exactly once.  ``speed`` compresses
the simulation: sample time 1 s of the thesis's loop every ``1 / speed`` wall seconds.
"""

from __future__ import annotations

import asyncio
import datetime as dt
import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

from stiction.schemas.loop_file import LoopFile, LoopNodes, OpcuaServer
from stiction.sim.publisher import loop_specs
from stiction.sim.stream import LoopStream

log = logging.getLogger(__name__)

NAMESPACE = "urn:stiction:plant"
VARIABLES = {"op": "OP", "pv": "PV", "sp": "SP", "mv": "MV", "mode": "MODE"}


@dataclass(frozen=True)
class PlantSettings:
    endpoint: str = "opc.tcp://127.0.0.1:4840"
    loops: int = 100
    seed: int = 0
    speed: float = 1.0
    warmup_s: float = 1000.0
    advertised_endpoint: str | None = None
    """The endpoint written into the loop file, where clients reach the server (default: ``endpoint``)."""
    certificate: str | None = None
    private_key: str | None = None
    """With both, the server accepts only Basic256Sha256 SignAndEncrypt (any client certificate)."""
    fault_every: int = 0
    """Every this many samples the first loop's PV is written with a Bad status (a sensor fault), to
    show a bridge counting it; 0: never."""


def loop_file(settings: PlantSettings, ids: list[str], ns: int, sample_time_s: float) -> LoopFile:
    """The loop file a bridge needs to read this plant."""
    return LoopFile(
        sample_time_s=sample_time_s,
        server=OpcuaServer(endpoint=settings.advertised_endpoint or settings.endpoint),
        loops={i: LoopNodes(**{role: f"ns={ns};s={i}.{name}" for role, name in VARIABLES.items()}) for i in ids},
    )


async def serve(
    settings: PlantSettings,
    stop: asyncio.Event,
    ready: Callable[[LoopFile], None] | None = None,
    status: Callable[[dict], None] | None = None,
) -> int:
    """Serve until ``stop``; returns the samples written per loop.  ``status`` gets, after every
    sample, the counts so far: samples written, grid points skipped (the server fell behind) and
    the last write pass in seconds."""
    from asyncua import Server, ua

    specs = loop_specs(settings.loops, settings.seed)
    ids = [f"plant-{i:05d}" for i in range(len(specs))]  # not the simulator's sim-*: both may run on one prefix
    stream = LoopStream(list(specs.values()))
    if settings.warmup_s > 0:
        stream.next(int(settings.warmup_s / stream.ts_s))
    dt_s = stream.ts_s / settings.speed

    server = Server()
    await server.init()
    server.set_endpoint(settings.endpoint)
    server.set_server_name("stiction simulated plant")
    if settings.certificate and settings.private_key:
        server.set_security_policy([ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt])
        await server.load_certificate(settings.certificate)
        await server.load_private_key(settings.private_key)
    else:
        server.set_security_policy([ua.SecurityPolicyType.NoSecurity])
    ns = await server.register_namespace(NAMESPACE)
    nodes: dict[str, list] = {role: [] for role in VARIABLES}
    for loop_id in ids:
        folder = await server.nodes.objects.add_folder(ua.NodeId(loop_id, ns), loop_id)
        for role, name in VARIABLES.items():
            var = await folder.add_variable(ua.NodeId(f"{loop_id}.{name}", ns), name, 1.0 if role == "mode" else 0.0)
            nodes[role].append(var.nodeid)
    written = skipped = 0
    async with server:
        if ready is not None:
            ready(loop_file(settings, ids, ns, dt_s))
        log.info("serving %d loops on %s, a sample every %.3g s", len(ids), settings.endpoint, dt_s)
        k = math.floor(time.time() / dt_s) + 1
        while not stop.is_set():
            delay = k * dt_s - time.time()
            if delay > 0:
                try:
                    await asyncio.wait_for(stop.wait(), delay)
                    break
                except TimeoutError:
                    pass
            if time.time() - k * dt_s > 5 * dt_s:  # fell behind (a stalled machine): skip, as a plant would
                now_k = math.floor(time.time() / dt_s)
                skipped += now_k - k
                k = now_k
            started = time.monotonic()
            chunk = stream.next(1)
            stamp = dt.datetime.fromtimestamp(k * dt_s, dt.UTC)
            for role, values in (("op", chunk.op), ("pv", chunk.pv), ("sp", chunk.sp), ("mv", chunk.mv)):
                for node_id, v in zip(nodes[role], values[:, 0], strict=True):
                    dv = ua.DataValue(ua.Variant(float(v), ua.VariantType.Double), SourceTimestamp=stamp)
                    await server.write_attribute_value(node_id, dv)
            if settings.fault_every and written % settings.fault_every == settings.fault_every - 1:
                bad = ua.DataValue(
                    ua.Variant(float("nan"), ua.VariantType.Double),
                    StatusCode=ua.StatusCode(ua.StatusCodes.BadSensorFailure),
                    SourceTimestamp=stamp,
                )
                await server.write_attribute_value(nodes["pv"][0], bad)
            written += 1
            k += 1
            if status is not None:
                status({"written": written, "skipped": skipped, "pass_s": time.monotonic() - started})
    return written
