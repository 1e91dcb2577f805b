"""One native thread per analysis process.

An analysis process (the vision worker, one of ``cyborgd analyze``'s per-core processes)
already owns a whole core. Its BLAS, OpenCV and numba thread pools would each start one
thread per core, spin against each other and against the other processes: numpy's OpenBLAS
took ~100 ms on two threads under load for a product that takes 0.57 ms on one (issue 44).

Two copies of OpenBLAS are loaded (numpy's and OpenCV's own), and the process may have
imported numpy before it is told (a spawned child re-imports its parent's main module):
the environment alone comes too late for those, so the limit is also applied at run time
with ``threadpoolctl``, which finds every BLAS/OpenMP library loaded in the process.
"""

from __future__ import annotations

import os
import sys

__all__ = ["single_thread"]

_ONE_THREAD = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")


def single_thread() -> None:
    """Run this process's native code on one thread: every BLAS/OpenMP library loaded now
    or later, OpenCV and numba. Call it first thing where an analysis process starts; it
    holds for the rest of the process and for the processes it starts."""
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
