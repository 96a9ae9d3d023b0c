"""How the ``meshplan`` process's C allocator treats the memory a run frees.

A run makes and drops thousands of arrays of a few megabytes (a 300k-face scan's per-face
arrays are 1-7 MB, the pen-and-ink raster's samples 13 MB). glibc's ``malloc`` maps each
block above its threshold (128 kB at first) on its own and gives it back to the kernel when
it is freed, so the next array of that size faults its pages in anew. In a virtual machine
whose free memory is handed back to the host (free page reporting, as on this project's
Firecracker machine) each such page costs a round trip to the host: a fresh process spent
1.0 s drawing the pen-and-ink raster that a process reusing its memory drew in 0.13 s, and
the whole 300k-face run spent 1.2-2.0 s of system time instead of 0.7-1.4 s.

:func:`keep_freed_memory` raises the two thresholds once, at the start of the command: blocks
up to :data:`MMAP_THRESHOLD_BYTES` come from the heap, and freed heap memory is kept for the
next arrays up to :data:`TRIM_THRESHOLD_BYTES`. Larger blocks (a 3M-face scan's per-face
arrays) are still mapped on their own and returned when freed, so the largest scans' peak
memory does not grow with fragments of the heap. The command line calls it
(:func:`meshplan.cli.entry`); a program that imports meshplan keeps its own allocator settings.
"""

from __future__ import annotations

import os
import sys

#: Blocks up to this size (bytes) come from the heap, whose freed memory the next arrays
#: reuse: every per-face array of a scan up to about 1.3 million faces (3 float64 columns),
#: the drawings' rasters and samples. glibc's own dynamic threshold stops at the same 32 MiB.
MMAP_THRESHOLD_BYTES = 32 * 2**20
#: Freed memory at the top of the heap is kept, not returned to the kernel, up to this size
#: (bytes): a run's working set of mid-sized arrays (about 0.4 GB at 300k faces).
TRIM_THRESHOLD_BYTES = 512 * 2**20
#: The user's own settings of the same thresholds, which are left alone.
_ENVIRONMENT = ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "GLIBC_TUNABLES")
#: ``mallopt`` parameters (glibc's ``malloc.h``).
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3


def keep_freed_memory() -> bool:
    """Set glibc's ``malloc`` to keep and reuse the memory the run frees (see the module).

    Returns
    -------
    bool
        Whether both thresholds were set: False off Linux, with another C library than glibc,
        or when the environment already sets them.
    """
    if not sys.platform.startswith("linux") or any(k in os.environ for k in _ENVIRONMENT):
        return False
    import ctypes

    try:
        libc = ctypes.CDLL(None)  # the C library the interpreter runs on
        mallopt = libc.mallopt
        if not hasattr(libc, "gnu_get_libc_version"):  # musl's mallopt accepts and ignores them
            return False
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES))
