"""Shared fixtures: a seeded RNG, guards against leaked threads and tasks, opt-in hardware."""

from __future__ import annotations

import asyncio
import subprocess
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(autouse=True)
def no_leaked_threads():
    """Fail a test that leaves non-daemon threads running (they hang the interpreter).
    The event loop's executor threads (``asyncio_N``) are joined when the loop closes,
    which pytest-asyncio does after this check."""
    before = set(threading.enumerate())
    yield
    leaked = [
        t
        for t in threading.enumerate()
        if t not in before and t.is_alive() and not t.daemon and not t.name.startswith("asyncio_")
    ]
    assert not leaked, f"test leaked threads: {leaked}"


@pytest.fixture(autouse=True)
async def no_leaked_tasks():
    """Fail a test that leaves asyncio tasks running once its fixtures are torn down: a
    forgotten task is a loop nobody stops, in a test as in the daemon."""
    yield
    me = asyncio.current_task()
    for _ in range(20):  # tasks that were just cancelled need a few turns of the loop
        leaked = [t for t in asyncio.all_tasks() if t is not me and not t.done()]
        if not leaked:
            return
        await asyncio.sleep(0.01)
    names = sorted(t.get_name() for t in leaked)
    pytest.fail(f"test leaked tasks: {names}", pytrace=False)


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Path]:
    """A real 3 MiB file system (tmpfs): a few full-resolution tiles fill it. Skipped,
    saying why, where it cannot be mounted (it needs root)."""
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=3m,mode=0755", "tmpfs", str(disk)],
        capture_output=True,
        text=True,
        check=False,
    )
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here (needs root): {mounted.stderr.strip()}")
    try:
        yield disk
    finally:
        subprocess.run(["umount", "-l", str(disk)], check=False)


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--ptu-port", default=None, help="serial port of a real PTU-46 for tests/hardware"
    )


@pytest.fixture
def ptu_port(request: pytest.FixtureRequest) -> str:
    port = request.config.getoption("--ptu-port")
    if not port:
        pytest.skip("needs a real PTU: pass --ptu-port=/dev/ttyUSB0")
    return port
