"""Shared fixtures: a seeded RNG, a guard against leaked threads, opt-in hardware."""

from __future__ import annotations

import threading

import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(autouse=True)
def no_leaked_threads():
    """Fail a test that leaves non-daemon threads running (they hang the interpreter)."""
    before = set(threading.enumerate())
    yield
    leaked = [t for t in threading.enumerate() if t not in before and t.is_alive() and not t.daemon]
    assert not leaked, f"test leaked threads: {leaked}"


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
