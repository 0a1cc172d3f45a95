"""The C heap of a ``stiction`` process and its children: freed memory kept for the next array, not handed back;
and, for the agent, the compiler's code handed back once its kernels are compiled (``release_library_pages``).

A diagnosis or a quantify run allocates and frees arrays of tens of kB to MB thousands of times a second.  glibc's
malloc gives the heap's free top back to the kernel once it passes 128 kB (and adapts its threshold only after a
large block was freed), so each new array faults its pages in afresh: on a 3,600-sample diagnosis a fifth of the
time was the kernel's (``stiction diagnose``, sensor lag loop: 11.1 s wall, 8.6 s user, 2.5 s system; with the heap
held 8.3 s, 8.1 s, 0.2 s; the peak RSS the same).  Arrays up to 32 MB (glibc's own ceiling for its adaptive
threshold) now come from the heap, and the heap is trimmed only past 128 MB free.

Set as environment variables, which glibc reads when a process starts (so the spawned workers of ``quantify``, the
sizing pool and the benchmarks inherit them), and for this process, already started, by ``mallopt``.  A value the
user set in the environment wins.  Elsewhere than glibc nothing changes.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from pathlib import Path

MMAP_THRESHOLD_BYTES = 32 * 1024 * 1024
TRIM_THRESHOLD_BYTES = 128 * 1024 * 1024
_SETTINGS = (("MALLOC_MMAP_THRESHOLD_", -3, MMAP_THRESHOLD_BYTES), ("MALLOC_TRIM_THRESHOLD_", -1, TRIM_THRESHOLD_BYTES))
"""(environment variable, glibc's ``mallopt`` parameter: M_MMAP_THRESHOLD, M_TRIM_THRESHOLD, default bytes)."""


def hold_freed_memory() -> bool:
    """Apply the settings to this process and its future children; False where the C library is not glibc."""
    libc = _glibc()
    if libc is None:  # musl and others: their allocator, their defaults
        return False
    mallopt = libc.mallopt
    for name, param, default in _SETTINGS:
        value = os.environ.setdefault(name, str(default))
        with contextlib.suppress(ValueError):  # the user's own value, unreadable: glibc ignored it at start, we too
            mallopt(param, int(value))
    return True


def _glibc():
    """The C library where it is glibc on Linux (``mallopt`` and ``madvise`` there); None elsewhere."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt, libc.madvise  # noqa: B018 - musl names its library otherwise; one without them is not glibc
    except (OSError, AttributeError):
        return None
    return libc


MADV_DONTNEED = 4
COMPILER_LIBRARY = "libllvmlite"
"""numba's compiler (LLVM): 69 MB of a ``stiction agent``'s resident set at 20,000 loops, touched while the kernels
compile or load at the warm-up and not after (a compiled kernel runs without it)."""


def release_library_pages(name: str = COMPILER_LIBRARY) -> int:
    """Hand back to the page cache the resident pages of a shared library ``name`` (its path contains it) that are
    clean copies of the file: its code and read-only data, never a page this process wrote (relocated data, its
    own variables).  Read again, a page faults back in from the file, identical.  Bytes released; 0 where
    ``/proc/self/smaps`` or ``madvise`` is not there."""
    libc = _glibc()
    if libc is None:
        return 0
    try:
        text = Path("/proc/self/smaps").read_text()
    except OSError:
        return 0
    libc.madvise.argtypes = (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int)
    released = 0
    for head, fields in _mappings(text):
        parts = head.split()
        if len(parts) < 6 or name not in parts[5] or "w" in parts[1]:
            continue
        if fields.get("Anonymous", 1) or fields.get("Private_Dirty", 1) or fields.get("Shared_Dirty", 1):
            continue  # a page written in it (copied on write): its contents are this process's, keep them
        lo, hi = (int(x, 16) for x in parts[0].split("-"))
        if libc.madvise(lo, hi - lo, MADV_DONTNEED) == 0:
            released += fields.get("Rss", 0) * 1024
    return released


def _mappings(smaps: str):
    """(the mapping's header line, {field: kB}) for each mapping of ``/proc/self/smaps``."""
    head, fields = None, {}
    for line in smaps.splitlines():
        key, _, rest = line.partition(":")
        if line[:1] and line[0] in "0123456789abcdef" and "-" in line.split(" ", 1)[0]:
            if head is not None:
                yield head, fields
            head, fields = line, {}
        elif rest.strip().endswith("kB"):
            fields[key] = int(rest.split()[0])
    if head is not None:
        yield head, fields
