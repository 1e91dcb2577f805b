"""Start ``cyborgd run`` (or ``router``) as a child process and wait until it serves (demo,
tests, benchmarks); make a field network's certificates for them.

The daemon prints one JSON line (``{"ready": true, ...}``) on stdout once its bus, PTU,
camera and worker are up; anything else it says goes to ``log``.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import re
import signal
import socket
import subprocess
import sys
from collections.abc import AsyncIterator, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cyborg.protocol.link import ADMIN_SPACE, locators, open_session
from cyborg.protocol.transport import Transport

__all__ = [
    "CERTS",
    "Daemon",
    "free_port",
    "launch",
    "make_certificates",
    "operator",
    "router",
    "simulated_config",
    "spawn",
    "watcher",
]

CERTS = Path(__file__).parents[1] / "systemd" / "cyborg-certs.sh"
"""The documented certificate recipe (openssl only)."""


def make_certificates(folder: Path, hosts: Sequence[str], users: Sequence[str]) -> Path:
    """A field network's certificates by the documented recipe: a CA, host certificates
    valid for 127.0.0.1 and localhost, user certificates; plus ``foreign/``, another CA
    with its own certificate for each user (what an impostor would hold). Returns
    ``folder``; each NAME has NAME.crt and NAME.key there."""

    def certs(where: Path, *args: str) -> None:
        subprocess.run(["sh", str(CERTS), str(where), *args], check=True, capture_output=True)

    certs(folder, "ca")
    for host in hosts:
        certs(folder, "host", host, "IP:127.0.0.1", "DNS:localhost")
    certs(folder / "foreign", "ca")
    for user in users:
        certs(folder, "user", user)
        certs(folder / "foreign", "user", user)
    return folder


def free_port() -> int:
    """A loopback TCP port that was free a moment ago (prefer port 0 where it can be read back)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def simulated_config(
    rig: str,
    archive: Path,
    *,
    listen: Sequence[str] = (),
    connect: Sequence[str] = (),
    time_scale: float = 1.0,
    ptu_query: str = "",
    seed: int = 3,
    scene: str = "outcrop",
    frame_rate: float = 10.0,
    survey: dict[str, Any] | None = None,
    zenoh: dict[str, Any] | None = None,
    sections: dict[str, dict[str, Any]] | None = None,
) -> str:
    """A ``cyborgd.toml`` for a simulated rig: the PTU-46 emulator on a pty behind the
    real serial driver, and the simulated camera on scene ``seed``: ``outcrop``, the
    cartoon cliff (cheap to draw: tests), or ``world``, detail at every range (the demo,
    slower to draw); ``zenoh``
    adds [zenoh] keys (TLS files, ``users``, ``insecure``), ``sections`` tables or keys of
    them (a real [camera], a [site])."""
    mode = "client" if connect and not listen else "peer"
    tables: dict[str, dict[str, Any]] = {
        "camera": {"url": f"sim://{scene}?seed={seed}&hfov=30"},
        "zenoh": {"mode": mode, "listen": list(listen), "connect": list(connect)},
        "frames": {"rate": frame_rate},
        "survey": dict(survey or {}),
    }
    tables["zenoh"] |= zenoh or {}
    for name, table in (sections or {}).items():  # e.g. [site], [record], a real [camera]
        tables[name] = tables.get(name, {}) | table
    lines = [
        f"rig = {json.dumps(rig)}",
        f"archive = {json.dumps(str(archive))}",
        f'ptu = "pty://?model=D46-17&time_scale={time_scale:g}{ptu_query}"',
    ]
    for name, table in tables.items():
        lines += [f"[{name}]", *(f"{k} = {json.dumps(v)}" for k, v in table.items())]
    return "\n".join(lines) + "\n"


@dataclass
class Daemon:
    proc: asyncio.subprocess.Process
    ready: dict[str, Any]
    log: Path

    @property
    def pid(self) -> int:
        return self.proc.pid

    async def stop(self, timeout: float = 15.0) -> int:
        """SIGTERM, wait; SIGKILL if it does not go. Returns the exit status."""
        if self.proc.returncode is None:
            with contextlib.suppress(ProcessLookupError):
                self.proc.send_signal(signal.SIGTERM)
            try:
                await asyncio.wait_for(self.proc.wait(), timeout)
            except TimeoutError:
                self.proc.kill()
                await self.proc.wait()
        return self.proc.returncode


async def spawn(
    args: Sequence[str],
    log: Path,
    timeout: float = 60.0,
    env: dict[str, str] | None = None,
    command: str = "run",
) -> Daemon:
    """``cyborgd COMMAND ARGS...`` (``run`` or ``router``), returned once it printed its
    ready line; the caller stops it."""
    log.parent.mkdir(parents=True, exist_ok=True)
    with log.open("ab") as err:
        proc = await asyncio.create_subprocess_exec(
            sys.executable,
            "-m",
            "cyborg.daemon",
            command,
            *args,
            stdin=asyncio.subprocess.DEVNULL,
            stdout=asyncio.subprocess.PIPE,
            stderr=err,
            env={**os.environ, **(env or {})},
        )
    daemon = Daemon(proc, {}, log)
    try:
        line = await asyncio.wait_for(proc.stdout.readline(), timeout)
        daemon.ready = json.loads(line) if line else {}
    except (TimeoutError, ValueError):
        daemon.ready = {}
    if not daemon.ready.get("ready"):
        await daemon.stop()
        tail = log.read_text(errors="replace").strip().splitlines()[-5:]
        raise RuntimeError(f"cyborgd {command} did not start:\n  " + "\n  ".join(tail))
    return daemon


@contextlib.asynccontextmanager
async def launch(
    args: Sequence[str], log: Path, timeout: float = 60.0, env: dict[str, str] | None = None
) -> AsyncIterator[Daemon]:
    """:func:`spawn`, stopped (SIGTERM, then SIGKILL) when the block ends."""
    daemon = await spawn(args, log, timeout, env)
    try:
        yield daemon
    finally:
        await daemon.stop()


@contextlib.contextmanager
def router() -> Iterator[str]:
    """A zenoh router in this process on a loopback port the kernel picked; yields its
    endpoint (read back from the router's admin space)."""
    session = open_session(Transport("router", listen=("tcp/127.0.0.1:0",)), ADMIN_SPACE)
    try:
        yield locators(session)[0]
    finally:
        session.close()


_WATCHER = """
import sys, time
from cyborg.protocol.link import open_session
from cyborg.protocol.transport import Transport
session = open_session(Transport("client", connect=(sys.argv[1],)))
subscriber = session.declare_subscriber(sys.argv[2], lambda sample: None)
print("watching", flush=True)
while True:
    time.sleep(60)
"""


@contextlib.asynccontextmanager
async def watcher(endpoint: str, key: str) -> AsyncIterator[asyncio.subprocess.Process]:
    """A subscriber to ``key`` in a process of its own, linked to ``endpoint``: tests and
    benchmarks freeze it (SIGSTOP) as a viewer whose radio link stalls. Killed at the end."""
    proc = await asyncio.create_subprocess_exec(
        sys.executable,
        "-c",
        _WATCHER,
        endpoint,
        key,
        stdout=asyncio.subprocess.PIPE,
        cwd=Path(__file__).parents[1],
    )
    try:
        if await asyncio.wait_for(proc.stdout.readline(), 30) != b"watching\n":
            raise RuntimeError(f"the watcher of {key} did not start")
        yield proc
    finally:
        with contextlib.suppress(ProcessLookupError):
            proc.send_signal(signal.SIGCONT)
            proc.kill()
        await proc.wait()


@contextlib.asynccontextmanager
async def operator(
    connect: str,
    rig: str,
    name: str,
    log: Path,
    extra: Sequence[str] = (),
    *,
    nofile: int | None = None,
) -> AsyncIterator[str]:
    """``cyborg operator`` on a free port (``extra``: more options, e.g. TLS files; ``nofile``:
    its open-file limit, as a small box or a ``LimitNOFILE=`` would set it); yields its page's
    URL, then stops it (SIGTERM) and raises if it did not exit cleanly."""
    limit = ("prlimit", f"--nofile={nofile}:{nofile}", "--") if nofile else ()
    with log.open("wb") as err:
        proc = await asyncio.create_subprocess_exec(
            *limit,
            sys.executable,
            "-m",
            "cyborg.clients",
            "operator",
            "--port",
            "0",
            "--rig",
            rig,
            "--connect",
            connect,
            "--name",
            name,
            *extra,
            stdout=asyncio.subprocess.PIPE,
            stderr=err,
        )
    try:
        line = (await asyncio.wait_for(proc.stdout.readline(), 30)).decode()
        url = re.search(r"http://\S+", line)
        if not url:
            raise RuntimeError(f"cyborg operator did not start: {line!r}; see {log}")
        yield url[0]
    finally:
        if proc.returncode is None:
            proc.terminate()
        code = await asyncio.wait_for(proc.wait(), 15)
    if code != 0:
        raise RuntimeError(f"cyborg operator exited with status {code}; see {log}")
