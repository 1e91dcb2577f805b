"""cyborgd's lifecycle as systemd and an operator see it: notify messages, start-up errors."""

from __future__ import annotations

import asyncio
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from cyborg.clients.launch import free_port, simulated_config, spawn
from cyborg.clients.rigclient import RigClient
from cyborg.protocol.messages import Hello, SurveyStatus
from cyborg.protocol.transport import Transport
from cyborg.protocol.version import PROTOCOL_MAJOR, PROTOCOL_MINOR

pytestmark = pytest.mark.timeout(60)


async def test_sd_notify_ready_watchdog_stopping(router: str, tmp_path: Path) -> None:
    path = tmp_path / "notify"
    with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as server:
        server.bind(str(path))
        server.setblocking(False)
        config = tmp_path / "c.toml"
        config.write_text(simulated_config("life", tmp_path / "a", connect=[router]))
        env = {"NOTIFY_SOCKET": str(path), "WATCHDOG_USEC": "200000"}
        daemon = await spawn(["--config", str(config)], tmp_path / "log", env=env)
        await asyncio.sleep(0.5)
        assert await daemon.stop() == 0
        messages = []
        while True:
            try:
                messages.append(server.recv(100).decode())
            except BlockingIOError:
                break
    assert messages[0] == "READY=1" and messages[-1] == "STOPPING=1"
    assert messages.count("WATCHDOG=1") >= 3  # every 0.1 s for half a second


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "cyborg.daemon", "run", *args],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )


def test_bad_config_is_refused_with_the_key(tmp_path: Path) -> None:
    config = tmp_path / "c.toml"
    config.write_text("[survey]\nrowz = 3\n")
    proc = _run("--config", str(config))
    assert proc.returncode == 2
    assert proc.stderr.strip() == "cyborgd: unknown key(s) in [survey]: rowz"


def test_missing_ptu_exits_with_one_line(tmp_path: Path) -> None:
    config = tmp_path / "c.toml"
    config.write_text(
        simulated_config("life", tmp_path / "a", listen=["tcp/127.0.0.1:0"]).replace(
            'ptu = "pty://?model=D46-17&time_scale=1"', f'ptu = "serial://{tmp_path}/ttyNOPE"'
        )
    )
    proc = _run("--config", str(config))
    assert proc.returncode == 1
    last = proc.stderr.strip().splitlines()[-1]
    assert last.startswith("cyborgd: ") and "ttyNOPE" in last
    assert "Traceback" not in proc.stderr


async def test_a_simulated_rig_in_one_command(tmp_path: Path) -> None:
    """``cyborgd run --sim`` (``make rig``): the emulator and the simulated camera, nothing
    to configure; clients reach it and survey."""
    port = free_port()
    archive = tmp_path / "rig"
    args = ["--sim", "--archive", str(archive), "--listen", f"tcp/127.0.0.1:{port}"]
    daemon = await spawn(args, tmp_path / "cyborgd.log")
    try:
        link = Transport("client", connect=(f"tcp/127.0.0.1:{port}",))
        with RigClient.open(link, "rig1", "trying") as client:
            await client.wait_alive()
            status = await client.command(SurveyStatus())
            assert status.state == "idle" and daemon.ready["archive"] == str(archive.resolve())
            hello = await client.command(Hello(PROTOCOL_MAJOR, PROTOCOL_MINOR))
            assert hello.rig == "rig1"
    finally:
        assert await daemon.stop() == 0
