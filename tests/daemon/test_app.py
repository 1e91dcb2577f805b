"""The supervisor in-process: ``run`` brings the rig up (bus, worker, PTU on a pty,
simulated camera), serves a client, and on SIGTERM stops cleanly with status 0."""

from __future__ import annotations

import asyncio
import io
import json
import os
import signal
from pathlib import Path

import pytest

from cyborg.clients.launch import free_port, simulated_config
from cyborg.clients.rigclient import RigClient
from cyborg.daemon.app import run
from cyborg.daemon.config import load
from cyborg.protocol.messages import Hello, Status, SurveyStatus
from cyborg.protocol.transport import Transport
from cyborg.protocol.version import PROTOCOL_MAJOR, PROTOCOL_MINOR

pytestmark = pytest.mark.timeout(120)


async def test_run_serves_then_stops_on_sigterm(tmp_path: Path) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    config = tmp_path / "cyborgd.toml"
    config.write_text(
        simulated_config("inproc", tmp_path / "archive", listen=[endpoint], frame_rate=0)
    )
    ready = io.StringIO()
    service = asyncio.create_task(run(load(config), ready_stream=ready))
    async with asyncio.timeout(60):
        while not ready.getvalue() and not service.done():
            await asyncio.sleep(0.05)
    line = json.loads(ready.getvalue())
    assert line["ready"] and line["rig"] == "inproc" and line["worker_pid"] > 0
    with RigClient.open(Transport("client", connect=(endpoint,)), "inproc", "tester") as client:
        await client.wait_alive()
        hello = await client.call(Hello(PROTOCOL_MAJOR, PROTOCOL_MINOR))
        assert isinstance(hello, Hello) and hello.rig == "inproc"
        status = await client.call(SurveyStatus())
        assert isinstance(status, Status) and status.state == "idle"
    os.kill(os.getpid(), signal.SIGTERM)  # the handler run() installed sets its stop
    assert await asyncio.wait_for(service, 30) == 0
    assert Path(line["archive"]).is_dir()
