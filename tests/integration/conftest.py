"""Real processes on loopback: an in-process zenoh router on port 0, ``cyborgd`` as a child
process with the PTU emulator on a pty and the simulated camera, clients in client mode."""

from __future__ import annotations

from collections.abc import AsyncIterator, Iterator
from pathlib import Path

import pytest

from cyborg.clients import launch
from cyborg.clients.launch import Daemon, simulated_config, spawn
from cyborg.clients.rigclient import RigClient
from cyborg.protocol.transport import Transport


@pytest.fixture
def router() -> Iterator[str]:
    """A router listening on a port the kernel picked; yields its endpoint."""
    with launch.router() as endpoint:
        yield endpoint


@pytest.fixture
async def start_daemon(router: str, tmp_path: Path) -> AsyncIterator:
    """Factory: start cyborgd with optional [survey] settings (and archive folder); all
    stopped at teardown."""
    daemons: list[Daemon] = []

    async def start(
        ptu_query: str = "",
        archive: Path | None = None,
        sections: dict | None = None,
        **survey: object,
    ) -> Daemon:
        config = tmp_path / f"cyborgd{len(daemons)}.toml"
        config.write_text(
            simulated_config(
                "itest",
                archive or tmp_path / "archive",
                connect=[router],
                time_scale=8,
                ptu_query=ptu_query,
                survey={"approach": [300, 60, 10], "simulate_approach": True, **survey},
                sections=sections,
            )
        )
        daemon = await spawn(["--config", str(config)], tmp_path / "cyborgd.log")
        daemons.append(daemon)
        return daemon

    yield start
    for daemon in daemons:
        await daemon.stop()


@pytest.fixture
async def daemon(start_daemon) -> Daemon:
    return await start_daemon()


@pytest.fixture
def client(router: str) -> Iterator[RigClient]:
    with RigClient.open(Transport("client", connect=(router,)), "itest", "tester") as c:
        yield c


@pytest.fixture
def other_client(router: str) -> Iterator[RigClient]:
    with RigClient.open(Transport("client", connect=(router,)), "itest", "intruder") as c:
        yield c
