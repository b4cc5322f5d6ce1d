"""How a ``tracecheck`` command's process uses memory for its large, short-lived arrays.

A command that reads a large file decodes it a block at a time into arrays of a few MB,
frees them and decodes the next. glibc's ``malloc`` serves allocations from 128 KiB up by
``mmap``, but each time such a mapping is freed it raises that threshold to its size (up to
32 MiB), so later blocks are carved from the heap, where they fragment and stay: ``replay``
of a 10⁵-episode file peaked at 115–143 MiB from run to run, against 105–108 MiB with
the threshold fixed, at the same speed (``benchmarks/bench_scale.py``). The command fixes it; the
library leaves the allocator of a program that imports it alone.
"""

from __future__ import annotations

import ctypes
import os
import sys

__all__ = ["MMAP_THRESHOLD", "steady_heap"]

#: Allocations of this many bytes and more are mapped and returned to the system when freed.
MMAP_THRESHOLD = 4 << 20
_M_MMAP_THRESHOLD = -3  # glibc's malloc.h


def steady_heap() -> bool:
    """Fix glibc's mmap threshold at :data:`MMAP_THRESHOLD` for this process (and the worker
    processes it forks); whether it did. Not on other C libraries, nor where the user set
    it themselves (``MALLOC_MMAP_THRESHOLD_``, ``GLIBC_TUNABLES=glibc.malloc.mmap_threshold=…``)."""
    if not sys.platform.startswith("linux") or "MALLOC_MMAP_THRESHOLD_" in os.environ \
            or "mmap_threshold" in os.environ.get("GLIBC_TUNABLES", ""):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD) == 1
