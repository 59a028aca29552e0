"""The C heap of ufmt's own processes: freed memory kept for reuse instead of returned.

A modal solve of the full basis allocates and frees arrays of 1-20 MB per design (the Newton
matrices at every root, the walks' state maps, the response's tables). With glibc's defaults
(an mmap threshold of 128 KiB that grows only with the blocks freed, a trim threshold twice
that) many of them come as fresh mappings and go back to the kernel when freed, so every
design faults its pages in again: ~3000-4000 minor page faults per design, about a fifth of a
full-basis solve's time. Raising both thresholds (blocks below 32 MiB from the heap; the heap
top kept up to 256 MiB) makes a design reuse the last one's pages (a handful of faults per
design). The cost: a process keeps its peak heap instead of shrinking after it.

Set by the CLI (:func:`ufmt.cli.main`) and by the study pool's own workers
(:func:`ufmt.studies.parallel.start_worker`), never in a caller's process by a library call
(a script calling ``ufmt.evaluate`` or ``run_study`` may call :func:`retain_freed_memory`
itself). Only on Linux with glibc (``mallopt``); elsewhere nothing.
The arithmetic does not change: the same operations on the same values, wherever they live.
"""

from __future__ import annotations

import ctypes
import functools
import sys

M_TRIM_THRESHOLD = -1  # glibc's mallopt parameters (malloc.h)
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD_BYTES = 32 << 20  # glibc's largest allowed on 64-bit
TRIM_THRESHOLD_BYTES = 256 << 20


@functools.cache
def retain_freed_memory() -> bool:
    """Raise this process's mmap and trim thresholds (module docstring), once; whether the
    C library took them (False off glibc)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL("libc.so.6").mallopt
    except (OSError, AttributeError):  # not glibc (e.g. musl)
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mmap = mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)
    trim = mallopt(M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES)
    return bool(mmap and trim)
