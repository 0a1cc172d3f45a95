"""A ``stiction`` process keeps the memory its arrays freed, and its spawned workers do too (``stiction.heap``).

Each case runs in a fresh interpreter: glibc's malloc settings belong to the process."""

import json
import os
import subprocess
import sys

import pytest

from stiction import cli
from stiction.heap import TRIM_THRESHOLD_BYTES

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc")

_FREED = """
import sys
{setup}
import numpy as np

def rss_mb():
    for line in open("/proc/self/status"):
        if line.startswith("VmRSS"):
            return int(line.split()[1]) / 1024

x = np.ones(20 * 1024 * 1024 // 8)  # 20 MB, every page touched
before = rss_mb()
del x
print(before - rss_mb())
"""


def _run(code: str, env: dict | None = None) -> str:
    environ = {k: v for k, v in os.environ.items() if not k.startswith("MALLOC_")}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env={**environ, **(env or {})})
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def test_an_array_freed_stays_with_the_process_where_the_command_holds_the_heap():
    given_back = float(_run(_FREED.format(setup="")))
    held = float(_run(_FREED.format(setup="from stiction.heap import hold_freed_memory; assert hold_freed_memory()")))
    assert given_back > 15  # glibc's default: a 20 MB block is its own mapping, unmapped when freed
    assert held < 5  # held: back in the heap, for the next array


def test_a_batch_command_holds_the_heap_for_its_spawned_workers_and_a_users_setting_wins(tmp_path):
    export = tmp_path / "loop.csv"
    export.write_text("t,op,pv\n" + "".join(f"{k},{50 + (k % 7)},{50 - (k % 5)}\n" for k in range(300)))
    code = (
        "import multiprocessing as mp, os, sys, stiction.cli as cli\n"
        "if __name__ == '__main__':\n"
        f"    cli.main(['quantify', {str(export)!r}, '--json'])\n"
        "    with mp.get_context('spawn').Pool(1) as pool:\n"
        "        print(pool.apply(os.getenv, ('MALLOC_MMAP_THRESHOLD_',)), os.getenv('MALLOC_TRIM_THRESHOLD_'))\n"
    )
    assert _run(code).splitlines()[-1] == f"{32 * 1024 * 1024} {TRIM_THRESHOLD_BYTES}"
    assert _run(code, {"MALLOC_TRIM_THRESHOLD_": "65536"}).splitlines()[-1] == f"{32 * 1024 * 1024} 65536"
    # a value that is no number: glibc ignores it, so does the command, and the work is done all the same
    out = _run(code, {"MALLOC_TRIM_THRESHOLD_": "lots"}).splitlines()
    assert out[-1] == f"{32 * 1024 * 1024} lots" and json.loads(out[0])["verdict"]


def test_the_services_keep_glibcs_own_heap():
    parser = cli.build_parser()
    assert cli.holds_heap(parser.parse_args(["diagnose", "x.csv"]))
    assert cli.holds_heap(parser.parse_args(["bench", "detect", "x"]))
    for service in (["agent"], ["demo"], ["bench", "throughput"], ["bench", "bridge"], ["sim"]):
        assert not cli.holds_heap(parser.parse_args(service)), service
