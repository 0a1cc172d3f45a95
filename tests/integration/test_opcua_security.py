"""A plant server that accepts only signed and encrypted sessions: the bridge with its certificate
reads it; without one it stops at once with one line saying the server refused it."""

import asyncio
import json
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest
import zenoh

from stiction.bridge import zenoh_session
from stiction.schemas import keys
from tests.integration.conftest import kill_left_over, start_cli, wait_until

pytest.importorskip("asyncua")
PREFIX = "test/opcua-security"


def _certificates(folder: Path) -> None:
    from asyncua.crypto.cert_gen import setup_self_signed_certificate
    from cryptography.x509.oid import ExtendedKeyUsageOID

    async def make():
        for name, uri, use in (
            ("server", "urn:stiction:plant", ExtendedKeyUsageOID.SERVER_AUTH),
            ("client", "urn:stiction:bridge", ExtendedKeyUsageOID.CLIENT_AUTH),
        ):
            await setup_self_signed_certificate(
                folder / f"{name}-key.pem", folder / f"{name}-cert.der", uri, "localhost", [use], {"commonName": name}
            )

    asyncio.run(make())


def test_the_bridge_reads_a_secure_server_with_its_certificate_and_is_refused_without(tmp_path):
    _certificates(tmp_path)
    opc = f"opc.tcp://127.0.0.1:{zenoh_session.free_loopback_port()}"
    loop_file = tmp_path / "loops.toml"
    endpoint = zenoh_session.free_loopback_endpoint()
    procs = {
        "plant": start_cli(
            "plant",
            "--loops",
            "2",
            "--endpoint",
            opc,
            "--speed",
            "10",
            "--loop-file",
            str(loop_file),
            "--certificate",
            str(tmp_path / "server-cert.der"),
            "--private-key",
            str(tmp_path / "server-key.pem"),
        )  # fmt: skip
    }
    batches = []
    got = threading.Event()

    def on_samples(sample):
        batches.append(json.loads(sample.payload.to_bytes()))
        got.set()

    try:
        wait_until(loop_file.exists, 60, "the plant's loop file")
        insecure = subprocess.run(
            [sys.executable, "-m", "stiction.cli", "bridge", "opcua", "--loop-file", str(loop_file),
             "--listen", zenoh_session.free_loopback_endpoint(), "--prefix", PREFIX],
            capture_output=True, text=True, timeout=60,
        )  # fmt: skip
        assert insecure.returncode == 2
        err = [x for x in insecure.stderr.splitlines() if x.startswith("stiction bridge: error:")]
        assert len(err) == 1 and "refused the bridge" in err[0], insecure.stderr
        with zenoh.open(zenoh_session.build([endpoint])) as session:
            sub = session.declare_subscriber(keys.samples_any(PREFIX), on_samples)
            security = f"Basic256Sha256,SignAndEncrypt,{tmp_path / 'client-cert.der'},{tmp_path / 'client-key.pem'}"
            procs["bridge"] = start_cli("bridge", "opcua", "--loop-file", str(loop_file), "--security", security,
                                     "--connect", endpoint, "--prefix", PREFIX)  # fmt: skip
            wait_until(lambda: {b["loop_id"] for b in batches} == {"plant-00000", "plant-00001"}, 60, "samples")
            sub.undeclare()
        procs["bridge"].send_signal(signal.SIGTERM)
        assert procs["bridge"].wait(timeout=20) == 0, procs["bridge"].stderr.read()
    finally:
        kill_left_over(procs)
