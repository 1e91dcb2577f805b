"""The vision worker runs its native code on one thread: it owns one core, and BLAS threads
spinning against each other made a 0.6 ms matrix product take ~100 ms (issue 44)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from cyborg.daemon.worker import VisionWorker


@dataclass(frozen=True)
class ThreadCounts:
    """A job that asks the worker how many threads each native pool of it would run."""

    returns: ClassVar[type] = dict

    def run(self) -> dict[str, int]:
        import cv2  # noqa: PLC0415 - asked inside the worker
        import numba  # noqa: PLC0415
        import numpy as np  # noqa: PLC0415
        import threadpoolctl  # noqa: PLC0415

        np.ones((64, 5)) @ np.ones((5, 5))  # numpy's BLAS is loaded and has run
        counts = {i["filepath"]: i["num_threads"] for i in threadpoolctl.threadpool_info()}
        return counts | {"opencv": cv2.getNumThreads(), "numba": numba.get_num_threads()}


async def test_the_worker_runs_one_blas_one_opencv_and_one_numba_thread() -> None:
    async with VisionWorker() as worker:
        counts = await worker.call(ThreadCounts())
    assert any("numpy" in name for name in counts), counts  # numpy's own OpenBLAS was seen
    assert set(counts.values()) == {1}, counts
