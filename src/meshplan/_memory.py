"""How the ``meshplan`` process's C allocator treats the memory a run frees, and when Python's
garbage collector runs.

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
memory does not grow with fragments of the heap. The process's threads share that one heap
(:data:`ARENAS`), so that what one frees the others reuse. The command line calls it
(:func:`meshplan.cli.entry`); a program that imports meshplan keeps its own allocator settings.

:func:`small_pages` keeps numpy from asking the kernel for transparent huge pages (2 MiB) for
its arrays of 4 MiB and more (``NUMPY_MADVISE_HUGEPAGE=0``, read when numpy loads). On this
project's machine each huge page faulted in is a 2 MiB round trip to the host, and a run faults
in gigabytes of fresh arrays: with huge pages the 3M-face scan spent 5.0-5.8 s of system time,
without 2.8-3.6 s, and ran in 14.3-15.4 s against 12.7-15.6 s (the 1M-face scan 1.6-2.0 s
against 1.1-1.2 s of system time, 5.8-8.1 s against 5.5-6.6 s; runs alternated, 2-4 each);
at 300k faces the two do not differ beyond the noise. The small pages' extra TLB misses cost
less CPU (0.3-0.8 s of user time at 3M faces) than the system time saved.

:func:`pause_collector` turns Python's cyclic garbage collector off while the program loads its
libraries (typer, numpy, scipy, numba and its compiler's machinery: about 120,000 objects, every
one of them kept for the life of the process), and :func:`resume_collector` sets what was loaded
aside for good (``gc.freeze``) and turns the collector back on before the run makes its first
array. Loading, the collector ran about 290 times, each full collection over every object loaded
so far: 0.07-0.09 s of the 0.6-0.7 s a fresh 300k-face run spends before it reads the scan, to
free 1,300 objects (a few hundred kB). Loaded with the collector off: 0.54 s instead of 0.68 s
(medians of six alternated fresh processes), the run 0.1 s sooner. Frozen, those objects are no
longer walked by the run's own collections either.
"""

from __future__ import annotations

import gc
import os
import sys

#: Blocks up to this size (bytes) come from the heap, whose freed memory the next arrays
#: reuse: every per-face array of a scan up to about 1.3 million faces (3 float64 columns),
#: the drawings' rasters and samples. glibc's own dynamic threshold stops at the same 32 MiB.
MMAP_THRESHOLD_BYTES = 32 * 2**20
#: Freed memory at the top of the heap is kept, not returned to the kernel, up to this size
#: (bytes): a run's working set of mid-sized arrays (about 0.4 GB at 300k faces).
TRIM_THRESHOLD_BYTES = 512 * 2**20
#: The heaps (glibc's arenas) the process's threads allocate from: one. By default each thread
#: that allocates gets a heap of its own (up to 8 per core), whose freed blocks, kept by the
#: thresholds above, the other threads cannot reuse: once the stages searched their parts in
#: threads (:data:`meshplan.geometry.SEARCH_THREADS`), the 3M-face run's peak rose from 1.70 to
#: 1.75-1.97 GB, the freed memory of the threads' heaps beside the main heap's. With one heap
#: shared by all: 1.68-1.69 GB, 1.6-1.8 s of system time against 2.0-2.4 s, 8.3-8.5 s end to
#: end against 8.3-8.9 s (three alternated pairs). The threads' blocks are large (numpy's
#: arrays), so that the shared heap's lock is taken seldom.
ARENAS = 1
#: The user's own settings of the same thresholds, which are left alone.
_ENVIRONMENT = ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "GLIBC_TUNABLES")
#: The user's own setting of the number of heaps, which is left alone.
_ARENA_VARIABLE = "MALLOC_ARENA_MAX"
#: numpy's switch for huge pages (documented among numpy's environment variables).
HUGEPAGE_VARIABLE = "NUMPY_MADVISE_HUGEPAGE"
#: ``mallopt`` parameters (glibc's ``malloc.h``).
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD, _M_ARENA_MAX = -1, -3, -8
#: Whether :func:`pause_collector` turned the collector off (and :func:`resume_collector` has
#: not yet turned it back on).
_paused = False


def keep_freed_memory() -> bool:
    """Set glibc's ``malloc`` to keep and reuse the memory the run frees (see the module), in
    one heap for all the process's threads (:data:`ARENAS`) unless ``MALLOC_ARENA_MAX`` says
    otherwise.

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
    if _ARENA_VARIABLE not in os.environ:
        mallopt(_M_ARENA_MAX, ARENAS)  # before the run starts a thread
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES))


def small_pages() -> bool:
    """Keep numpy from asking for huge pages (see the module), unless the user set
    ``NUMPY_MADVISE_HUGEPAGE``. It takes effect only where numpy is not loaded yet (numpy reads
    the variable once, when it loads), and it is inherited by the processes this one starts.

    Returns
    -------
    bool
        Whether the setting is meshplan's (False off Linux, where numpy asks for none, or when
        the environment already sets it).
    """
    if not sys.platform.startswith("linux") or HUGEPAGE_VARIABLE in os.environ:
        return False
    os.environ[HUGEPAGE_VARIABLE] = "0"
    return True


def pause_collector() -> bool:
    """Turn Python's cyclic garbage collector off while the program loads its libraries (see the
    module), until :func:`resume_collector`. A collector the program finds off (a user's
    ``gc.disable()``) is left so.

    Returns
    -------
    bool
        Whether the collector was on and is now paused.
    """
    global _paused
    if _paused or not gc.isenabled():
        return False
    gc.disable()
    _paused = True
    return True


def resume_collector() -> bool:
    """Set every object loaded so far aside from the collector for good (``gc.freeze``: they live
    as long as the process) and turn the collector back on, if :func:`pause_collector` paused
    it; otherwise do nothing. Safe to call more than once.

    Returns
    -------
    bool
        Whether the collector was resumed by this call.
    """
    global _paused
    if not _paused:
        return False
    _paused = False
    gc.freeze()
    gc.enable()
    return True
