"""The vision worker dies with its daemon, however the daemon dies."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import pytest


@dataclass(frozen=True)
class Nap:
    """A job that only sleeps."""

    seconds: float
    returns: ClassVar[type] = type(None)

    def run(self) -> None:
        time.sleep(self.seconds)


PARENT = """
import asyncio
from cyborg.daemon.worker import VisionWorker
from tests.daemon.test_worker_lifetime import Nap

async def main():
    worker = VisionWorker()
    worker.start()
    print(worker.pid, flush=True)
    await worker.call(Nap(120))  # a job far longer than the test

asyncio.run(main())
"""


def _gone(pid: int) -> bool:
    try:
        return "State:\tZ" in Path(f"/proc/{pid}/status").read_text()
    except FileNotFoundError:
        return True


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="parent-death signal: Linux")
def test_worker_mid_job_dies_with_a_killed_daemon() -> None:
    """A SIGKILLed daemon cannot close the pipe or stop its worker; the kernel must take the
    worker with it, in the middle of a two-minute job."""
    root = Path(__file__).parents[2]
    parent = subprocess.Popen(
        [sys.executable, "-c", PARENT], cwd=root, stdout=subprocess.PIPE, text=True
    )
    try:
        worker = int(parent.stdout.readline())
        time.sleep(0.5)  # the job is on its way
        assert not _gone(worker)
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait(10)
        deadline = time.monotonic() + 30  # a quarter of the job: an orphan would still run
        while not _gone(worker):
            assert time.monotonic() < deadline, f"worker {worker} outlived its daemon"
            time.sleep(0.05)
    finally:
        parent.kill()
        parent.wait()
