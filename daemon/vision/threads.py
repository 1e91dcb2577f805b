"""One native thread per analysis process, and freed memory kept for the next image.

An analysis process (the vision worker, one of ``cyborgd analyze``'s per-core processes)
already owns a whole core. Its BLAS, OpenCV and numba thread pools would each start one
thread per core, spin against each other and against the other processes: numpy's OpenBLAS
took ~100 ms on two threads under load for a product that takes 0.57 ms on one (issue 44).

Two copies of OpenBLAS are loaded (numpy's and OpenCV's own), and the process may have
imported numpy before it is told (a spawned child re-imports its parent's main module):
the environment alone comes too late for those, so the limit is also applied at run time
with ``threadpoolctl``, which finds every BLAS/OpenMP library loaded in the process.

An analysis makes and frees the same few dozen arrays of 0.5-2.5 MB for every image. glibc
hands blocks that big back to the system when they are freed and maps fresh zeroed pages
for the next, ~1900 page faults (3 ms of system time) an image at the working size; told to
serve them from its heap and keep what is freed (``mallopt``), it reuses the same pages.
"""

from __future__ import annotations

import ctypes
import os
import sys

__all__ = ["single_thread"]

_ONE_THREAD = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
"""glibc's ``mallopt`` parameters (malloc.h)."""
_HEAP_BLOCKS = 32 << 20
"""Blocks up to 32 MiB (glibc's most) come from the heap: every array of an analysis at the
working size; a 100 MP plane is still mapped, and unmapped when freed."""
_KEPT = 64 << 20
"""Freed heap memory kept for the next image, up to 64 MiB."""


def single_thread() -> None:
    """Run this process's native code on one thread: every BLAS/OpenMP library loaded now
    or later, OpenCV and numba; and keep the memory it frees (:func:`_keep_freed_memory`).
    Call it first thing where an analysis process starts; the threads hold for the rest of
    the process and for the processes it starts."""
    _keep_freed_memory()
    numba = sys.modules.get("numba")
    for name in _ONE_THREAD:
        os.environ[name] = "1"  # read by libraries loaded from now on (numba, child processes)
    if numba is not None:
        # numba loaded already sized its pool, and re-reads the environment at each compile:
        # a changed NUMBA_NUM_THREADS would then be refused ("once the threads have been
        # launched"). Its pool keeps its size; set_num_threads below uses one of it.
        os.environ["NUMBA_NUM_THREADS"] = str(numba.config.NUMBA_NUM_THREADS)
    import cv2  # noqa: PLC0415 - loaded here so its OpenBLAS is limited below
    import numpy  # noqa: F401, PLC0415 - idem
    import threadpoolctl  # noqa: PLC0415 - only analysis processes need it

    threadpoolctl.threadpool_limits(1)  # the libraries already loaded; no `with`: it stays
    cv2.setNumThreads(1)
    if numba is not None:
        numba.set_num_threads(1)


def _keep_freed_memory() -> None:
    """glibc: serve blocks up to ``_HEAP_BLOCKS`` from the heap and keep up to ``_KEPT`` of
    freed memory in it. Elsewhere (musl, macOS) the allocator is left as it is."""
    mallopt = getattr(ctypes.CDLL(None), "mallopt", None)
    if mallopt is None:
        return
    mallopt(_M_MMAP_THRESHOLD, _HEAP_BLOCKS)
    mallopt(_M_TRIM_THRESHOLD, _KEPT)
