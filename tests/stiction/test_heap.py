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


_RELEASED = """
import numpy as np
from stiction.heap import COMPILER_LIBRARY, release_library_pages
from stiction.quantify import pipeline
from stiction.quantify.window import Window

def resident_mb(name=None):
    if name is None:
        return next(int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmRSS")) / 1024
    total, inside = 0, False
    for line in open("/proc/self/smaps"):
        if line[:1] in "0123456789abcdef" and "-" in line.split(" ", 1)[0]:
            inside = name in line
        elif inside and line.startswith("Rss:"):
            total += int(line.split()[1])
    return total / 1024

t = np.arange(1000)
rng = np.random.default_rng(4)
op = 50 + 10 * np.sign(np.sin(t / 9)) + rng.normal(0, 0.5, t.size)
windows = [Window("a", np.cumsum(op - 50) / 50 + 50, op, 1.0, 1000.0, "level"), Window("b", op, op[::-1])]
quantifier = pipeline.Quantifier()
pipeline.warm_up()
before = [r.model_dump_json() for r in quantifier.quantify(windows)]
mapped, rss = resident_mb(COMPILER_LIBRARY), resident_mb()
released = release_library_pages() / 2**20
after = [r.model_dump_json() for r in quantifier.quantify(windows)]
print(mapped, released, rss - resident_mb(), resident_mb(COMPILER_LIBRARY), after == before)
"""


def test_the_compilers_code_is_handed_back_after_the_warm_up_and_the_reports_do_not_change():
    """The agent releases numba's compiler (LLVM) once its kernels are compiled: the pages leave the resident set,
    none of them is read again by the reports, and the reports are the same."""
    mapped, released, rss_fell, left, same = _run(_RELEASED).split()
    assert float(mapped) > 20 and float(released) > 0.8 * float(mapped)
    assert float(rss_fell) > 0.7 * float(released) and float(left) < 0.2 * float(mapped)
    assert same == "True"


def test_only_clean_pages_are_released_and_the_process_goes_on():
    """A library's pages this process wrote (its relocated data, its variables) are its own and stay: released here,
    every library whose path says python (the interpreter's, numpy's, the standard library's extensions) goes on
    working; had a written page been dropped, its pointers would be the file's again and the process would fail."""
    code = (
        "from stiction.heap import release_library_pages\n"
        "import numpy as np\n"
        "x = np.arange(10.0)\n"
        "n = release_library_pages('python')\n"
        "import decimal, json\n"
        "print(n > 1e6, json.dumps({'a': [1, 2]}), decimal.Decimal('1.5') * 2, float(np.fft.rfft(x)[0].real))\n"
    )
    assert _run(code) == 'True {"a": [1, 2]} 3.0 45.0'
