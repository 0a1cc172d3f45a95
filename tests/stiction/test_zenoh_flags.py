"""Bad Zenoh flags end with one line naming what was wrong, exit code 2, no traceback."""

import subprocess
import sys

import pytest


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (["agent", "--connect", "nonsense"], "nonsense"),
        (["sim", "--config", "/nonexistent/zenoh.json5"], "/nonexistent/zenoh.json5"),
        (["sim", "--prefix", "plant/*"], "prefix"),
        (["agent", "--listen", "tcp/127.0.0.1:notaport"], "notaport"),
    ],
)
def test_bad_zenoh_flags(argv, expected):
    done = subprocess.run([sys.executable, "-m", "stiction.cli", *argv], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and expected in lines[0] and "Traceback" not in done.stderr, done.stderr
