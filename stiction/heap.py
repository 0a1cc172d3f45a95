"""The C heap of a ``stiction`` process and its children: freed memory kept for the next array, not handed back.

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

MMAP_THRESHOLD_BYTES = 32 * 1024 * 1024
TRIM_THRESHOLD_BYTES = 128 * 1024 * 1024
_SETTINGS = (("MALLOC_MMAP_THRESHOLD_", -3, MMAP_THRESHOLD_BYTES), ("MALLOC_TRIM_THRESHOLD_", -1, TRIM_THRESHOLD_BYTES))
"""(environment variable, glibc's ``mallopt`` parameter: M_MMAP_THRESHOLD, M_TRIM_THRESHOLD, default bytes)."""


def hold_freed_memory() -> bool:
    """Apply the settings to this process and its future children; False where the C library is not glibc."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL("libc.so.6").mallopt
    except (OSError, AttributeError):  # musl and others: their allocator, their defaults
        return False
    for name, param, default in _SETTINGS:
        value = os.environ.setdefault(name, str(default))
        with contextlib.suppress(ValueError):  # the user's own value, unreadable: glibc ignored it at start, we too
            mallopt(param, int(value))
    return True
