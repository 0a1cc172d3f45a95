"""Our Zenoh sessions map no shared-memory pool: a 16 MB pool in /dev/shm for each process that sends a few
kB at once was an agent's RSS for nothing loopback TCP does not carry as well (``SHARED_MEMORY``)."""

import sys
import threading
from pathlib import Path

import pytest
import zenoh

from stiction.bridge.zenoh_session import build, free_loopback_endpoint, open_session

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/maps")


def _zenoh_pools() -> list[str]:
    return [line for line in Path("/proc/self/maps").read_text().splitlines() if line.endswith(".zenoh")]


def _send_large(cfg_a, cfg_b) -> None:
    """``a`` puts 20 kB that ``b`` receives."""
    a = open_session(cfg_a)
    b = open_session(cfg_b)
    got = threading.Event()
    sub = b.declare_subscriber("test/shm/x", lambda s: got.set())
    try:
        for _ in range(50):  # until the two peers have met
            a.put("test/shm/x", b"x" * 20_000)
            if got.wait(0.1):
                break
        assert got.is_set()
    finally:
        sub.undeclare()
        a.close()
        b.close()


def test_a_large_message_maps_no_shared_memory():
    before = _zenoh_pools()
    here = free_loopback_endpoint()
    _send_large(build(listen=[here]), build(connect=[here]))
    assert _zenoh_pools() == before


def test_a_config_file_decides_shared_memory_for_itself(tmp_path):
    """Where a file says nothing of shared memory Zenoh's default holds; where it says, the file's word does.
    (Whether Zenoh then maps a pool depends on the machine: CI's did not, so this reads the configuration.)"""
    key = "transport/shared_memory/enabled"
    file = tmp_path / "peer.json5"
    said_expected = [("", zenoh.Config().get_json(key))]
    said_expected += [(f", transport: {{shared_memory: {{enabled: {word}}}}}", word) for word in ("false", "true")]
    for said, expected in said_expected:
        file.write_text('{mode: "peer", scouting: {multicast: {enabled: false}}' + said + "}")
        assert build(config_file=file).get_json(key) == expected
    assert build(listen=[free_loopback_endpoint()]).get_json(key) == "false"


_THREADS = """
import os, threading
from stiction.bridge.zenoh_session import build, free_loopback_endpoint, open_session
here = free_loopback_endpoint()
a, b = open_session(build(listen=[here])), open_session(build(connect=[here]))
got = threading.Event()
sub = b.declare_subscriber("test/rt/x", lambda s: got.set())
for _ in range(50):
    a.put("test/rt/x", b"x")
    if got.wait(0.1):
        break
assert got.is_set()
print(" ".join(open(f"/proc/self/task/{t}/comm").read().strip() for t in os.listdir("/proc/self/task")))
sub.undeclare()
a.close()
b.close()
"""


def _python(code: str, env: dict, check: bool = False) -> str:
    """What ``code`` prints in a fresh process (Zenoh reads ``ZENOH_RUNTIME`` once a process), with ``env`` and no
    ``ZENOH_RUNTIME`` of this one's."""
    import os
    import subprocess

    base = {k: v for k, v in os.environ.items() if k != "ZENOH_RUNTIME"}
    return subprocess.run([sys.executable, "-c", code], env=base | env, capture_output=True, text=True, timeout=60,
                          check=check).stdout  # fmt: skip


def _zenoh_threads(env: dict) -> set[str]:
    """The kinds of Zenoh's threads (``rx``, ``app``, ...) in a process whose two sessions exchanged a message."""
    return {name.rsplit("-", 1)[0] for name in _python(_THREADS, env, check=True).split() if "-" in name}


def test_zenoh_receives_on_the_application_runtime_unless_the_environment_says_otherwise():
    ours = _zenoh_threads({})
    assert "app" in ours and not ours & {"rx", "acc"}  # one worker thread, not three more with arenas of their own
    theirs = _zenoh_threads({"ZENOH_RUNTIME": "(rx: (worker_threads: 1))"})
    assert "rx" in theirs  # a user's setting is kept


def test_a_runtime_setting_zenoh_cannot_read_is_one_error_that_names_it():
    """Zenoh panics on a ``ZENOH_RUNTIME`` it cannot parse; the user reads which variable was wrong."""
    code = (
        "from stiction.bridge.zenoh_session import build, open_session\n"
        "from stiction.schemas.errors import InputError\n"
        "try:\n    open_session(build())\nexcept InputError as e:\n    print(e)\n"
    )
    out = _python(code, {"ZENOH_RUNTIME": "(rx: (bogus: 1))"})
    assert out.startswith("cannot open a Zenoh session: ZENOH_RUNTIME='(rx: (bogus: 1))' is not a runtime setting")
