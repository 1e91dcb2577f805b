"""``cyborgd analyze --scheduler tcp://HOST:8786``: the per-image job on a Dask cluster.

Each task carries an image's path and its folder, so the workers must see the same files
under the same paths (a shared or network file system) and run this package with the same
science (``pip install 'cyborg-astrobiologist[cluster]'`` on every node). Start one worker
process per core with one thread each (``dask worker tcp://HOST:8786 --nworkers N
--nthreads 1``), as the local run does: the science is CPU-bound and each process runs its
native code on one thread.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from concurrent.futures import Executor
from contextlib import contextmanager

_LOGGER = logging.getLogger(__name__)

__all__ = ["ClusterError", "cluster_executor"]

INSTALL = "pip install 'cyborg-astrobiologist[cluster]'"


class ClusterError(RuntimeError):
    """The cluster cannot be used: dask.distributed is missing or the scheduler is out of
    reach; the message says which and what to do."""


@contextmanager
def cluster_executor(address: str, timeout: float = 30.0) -> Iterator[tuple[Executor, int]]:
    """A ``concurrent.futures`` executor on the Dask scheduler at ``address``, and how many
    tasks to keep in flight (four per worker thread, at least four)."""
    try:
        from distributed import Client  # noqa: PLC0415 - an optional extra
    except ImportError:
        raise ClusterError(
            f"--scheduler needs dask.distributed, which is not installed: {INSTALL}"
        ) from None
    try:
        client = Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ClusterError(f"cannot reach the Dask scheduler at {address}: {exc}") from None
    with client:
        threads = sum(client.nthreads().values())
        _LOGGER.info("Dask scheduler %s: %d worker threads", address, threads)
        yield client.get_executor(pure=False), 4 * max(1, threads)
