"""The emulator on a pseudo-terminal, with fault injection declared as data.

The real serial driver opens the pty's slave (or a stable symlink to it, like the udev
``/dev/ptu`` link on the rig) and cannot tell it from a unit on a USB adapter. Faults
are :class:`Fault` rules matched against the commands the unit receives: garbage on a line
of its own before a reply, line noise glued onto a reply (no line end of its own, so the
reply's line arrives corrupted), a reply rewritten to something else, a dropped reply, a
slow reply, a hang-up (the pty closes, the link disappears and comes back later on a new
pty, like an unplugged adapter). :meth:`PtyEmulatorServer.inject` puts noise on the line at
any moment. A power-up banner is printed at start and after each come-back. Both
directions are paced at the line's baud rate (a reply leaves once the command's bytes would
have arrived), so command round trips take as long as on the real 9600-baud link.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import signal
import tty
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, get_args

from .emulator import Ptu46Emulator

__all__ = ["BANNER", "Fault", "PtyEmulatorServer", "parse_fault", "serve"]

_LOGGER = logging.getLogger(__name__)

BANNER = (
    b"\r\nPan-Tilt Controller v2.12.1d1, (C)2003 Directed Perception, Inc.\r\nInitializing...\r\n"
)
_TICK_BUSY = 0.002
_TICK_IDLE = 0.02

Action = Literal["garbage", "noise", "rewrite", "drop", "delay", "hangup"]
_ACTIONS = get_args(Action)
NOISE = b"\xf3\x1b~#\x9c%\xe2*\x7f\x8a5\xd1!\xbb\x06\x93"
"""A 16-byte burst as a cheap USB-serial adapter picks it up: no line end of its own."""
_DATA: dict[str, bytes] = {
    "garbage": b"\x00\xfe#%garbage~\r\n",
    "noise": NOISE,
    "rewrite": b"* 99999\r\n",
}


@dataclass
class Fault:
    """One injected fault: ``action`` on the ``nth`` command starting with ``match``.

    ``count`` consecutive matches are affected (0 = every match from the nth on).
    ``data`` is what ``garbage`` and ``noise`` write before the reply and what ``rewrite``
    sends instead of it (each action has a default); ``seconds`` the reply delay or the
    hang-up length.
    """

    action: Action
    match: str = ""
    nth: int = 1
    count: int = 1
    data: bytes = b""
    seconds: float = 0.5
    seen: int = 0
    fired: int = 0
    """How often it struck: a fault test checks its fault really happened."""

    def __post_init__(self) -> None:
        self.data = self.data or _DATA.get(self.action, b"")

    def fires(self, token: str) -> bool:
        if not token.upper().startswith(self.match.upper()):
            return False
        self.seen += 1
        k = self.seen - self.nth
        strikes = k >= 0 and (self.count == 0 or k < self.count)
        self.fired += strikes
        return strikes


def parse_fault(spec: str) -> Fault:
    """``action[:match[:nth[:seconds]]]``, e.g. ``drop:PP:2`` or ``hangup:A:1:1.5``.

    >>> f = parse_fault("delay:TP:3:0.8")
    >>> f.action, f.match, f.nth, f.seconds
    ('delay', 'TP', 3, 0.8)
    """
    parts = spec.split(":")
    if parts[0] not in _ACTIONS or len(parts) > 4:
        raise ValueError(f"bad fault {spec!r}: want action[:match[:nth[:seconds]]]")
    fault = Fault(parts[0])  # type: ignore[arg-type]
    if len(parts) > 1:
        fault.match = parts[1]
    if len(parts) > 2:
        fault.nth = int(parts[2])
    if len(parts) > 3:
        fault.seconds = float(parts[3])
    return fault


class PtyEmulatorServer:
    """Serve one :class:`Ptu46Emulator` on a pty until :meth:`close`."""

    def __init__(
        self,
        emulator: Ptu46Emulator,
        *,
        link: Path | None = None,
        faults: list[Fault] | None = None,
        banner: bytes | None = None,
        baud: int = 9600,
    ) -> None:
        self.emulator = emulator
        self.baud = baud
        """Output is paced at 10 bits per byte like the real line; 0 sends at once."""
        self.link = link
        self.faults = list(faults or [])
        self.banner = banner
        self._master = self._slave = -1
        self._token = bytearray()
        self._out: list[tuple[float, bytes]] = []
        self._loop: asyncio.AbstractEventLoop | None = None
        self._ticker: asyncio.Task[None] | None = None
        self._back: asyncio.TimerHandle | None = None
        self.pty_path = ""
        self.hangups = 0

    @property
    def path(self) -> str:
        """What to open: the stable link if there is one, else the pty itself."""
        return str(self.link) if self.link else self.pty_path

    @property
    def connected(self) -> bool:
        return self._master >= 0

    async def start(self) -> PtyEmulatorServer:
        self._loop = asyncio.get_running_loop()
        self._open()
        self._ticker = self._loop.create_task(self._tick(), name="cyborgd.emulator.tick")
        return self

    async def close(self) -> None:
        if self._ticker:
            self._ticker.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._ticker
            self._ticker = None
        if self._back:
            self._back.cancel()
        self._shut()

    async def __aenter__(self) -> PtyEmulatorServer:
        return await self.start()

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    # -- pty lifecycle -------------------------------------------------------------------

    def _open(self) -> None:
        assert self._loop is not None
        master, slave = os.openpty()
        # Raw before anyone opens it: no echo, no CR/LF translation by the line discipline.
        tty.setraw(slave)
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        self.pty_path = os.ttyname(slave)
        if self.link:
            tmp = self.link.with_name(self.link.name + ".tmp")
            tmp.unlink(missing_ok=True)
            tmp.symlink_to(self.pty_path)
            tmp.replace(self.link)
        self._loop.add_reader(master, self._on_readable)
        if self.banner:
            self._send(self.banner)
        _LOGGER.debug("PTU emulator on %s", self.path)

    def _shut(self) -> None:
        if self._master >= 0 and self._loop:
            self._loop.remove_reader(self._master)
        for fd in (self._master, self._slave):
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = -1
        self._out.clear()
        self._token.clear()
        if self.link:
            self.link.unlink(missing_ok=True)

    def hangup(self, seconds: float) -> None:
        """Close the pty now (the host sees the device vanish); come back after ``seconds``."""
        assert self._loop is not None
        self.hangups += 1
        self._shut()
        self._back = self._loop.call_later(seconds, self._open)

    def inject(self, data: bytes) -> None:
        """Write bytes the host did not ask for (noise on the line, a reboot banner)."""
        self._send(data)

    # -- data path -----------------------------------------------------------------------

    def _on_readable(self) -> None:
        try:
            data = os.read(self._master, 4096)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            return
        for byte in data:
            b = bytes((byte,))
            if b in b" \r\n":
                token = self._token.decode("ascii", "replace")
                self._token.clear()
                # The unit acts once the command has crossed the line: its own bytes' time.
                wire = 10 * (len(token) + 1) / self.baud if self.baud else 0.0
                self._command(token, b, wire)
                if not self.connected:
                    return
            else:
                self._token += b
                self._send(self.emulator.receive(b))

    def _command(self, token: str, delimiter: bytes, wire: float) -> None:
        fired = [f for f in self.faults if token and f.fires(token)]
        out = self.emulator.receive(delimiter)
        delay = wire
        for f in fired:
            _LOGGER.info("injected fault: %s on %r", f.action, token)
            if f.action in ("garbage", "noise"):
                self._send(f.data)
            elif f.action == "rewrite":
                out = f.data
            elif f.action == "drop":
                out = b""
            elif f.action == "delay":
                delay = max(delay, wire + f.seconds)
            elif f.action == "hangup":
                self.hangup(f.seconds)
                return
        self._send(out, delay)

    def _send(self, data: bytes, delay: float = 0.0) -> None:
        if not data or not self.connected:
            return
        assert self._loop is not None
        due = self._loop.time() + delay
        # Later bytes never overtake a delayed reply: the line is a single stream.
        if self._out:
            due = max(due, self._out[-1][0])
        if self.baud:
            due += 10 * len(data) / self.baud
        self._out.append((due, data))
        self._loop.call_at(due, self._flush)

    def _flush(self) -> None:
        assert self._loop is not None
        now = self._loop.time()
        while self._out and self._out[0][0] <= now and self.connected:
            due, data = self._out[0]
            try:
                n = os.write(self._master, data)
            except BlockingIOError:
                return
            except OSError:
                self._out.clear()
                return
            if n < len(data):
                self._out[0] = (due, data[n:])
                return
            self._out.pop(0)

    async def _tick(self) -> None:
        while True:
            await asyncio.sleep(_TICK_BUSY if self.emulator.busy else _TICK_IDLE)
            if self.connected:
                self._send(self.emulator.poll())


async def serve(server: PtyEmulatorServer, tcp: tuple[str, int] | None = None) -> None:
    """Run ``server`` until SIGTERM or SIGINT; print the path to open first, and with
    ``tcp`` (host, port) serve it there too and print that URL."""
    from .tcpserver import TcpLineServer  # noqa: PLC0415 - only with --tcp

    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)
    async with server:
        print(server.path, flush=True)
        if tcp is None:
            await stop.wait()
            return
        line = await TcpLineServer(server.path, *tcp).start()
        print(line.url, flush=True)
        try:
            await stop.wait()
        finally:
            await line.close()
