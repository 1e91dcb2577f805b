"""Backends around the emulator: in-process (``emu://``) and on a pty (``pty://``).

Both take ``model``, ``time_scale`` and a real head's errors (:class:`HeadErrors`:
``pointing_error``, ``backlash``, ``error_seed``), and expose where the head truly looks as
:attr:`EmulatedPtu.true_pose` for a simulated camera to render from.
"""

from __future__ import annotations

import asyncio
import tempfile
from collections.abc import Awaitable, Callable
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

from .base import LinkState
from .commanded import CommandedPtu
from .emulator import Ptu46Emulator
from .emulator_errors import HeadErrors
from .errors import PtuConnectionError, PtuTimeoutError
from .models import MODELS
from .ptyserver import BANNER, Fault, PtyEmulatorServer, parse_fault
from .serial import SerialPtu
from .tcpserver import TcpLineServer
from .wire import LineFramer, Reply, format_command, match_reply

__all__ = ["EmulatedPtu", "PtyPtu", "TcpPtu"]

_POLL = 0.002


def _emulator(query: dict[str, list[str]]) -> Ptu46Emulator:
    """The emulator a URL's query asks for: ``model`` (default D46-17), ``time_scale`` and
    the head's errors (:meth:`HeadErrors.from_query`, none by default)."""
    name = query.get("model", ["D46-17"])[-1]
    if name not in MODELS:
        raise ValueError(f"unknown PTU model {name!r}; known: {', '.join(MODELS)}")
    return Ptu46Emulator(
        MODELS[name],
        time_scale=float(query.get("time_scale", ["1"])[-1]),
        errors=HeadErrors.from_query(query),
    )


def _true_pose(emulator: Ptu46Emulator) -> Callable[[], Awaitable[tuple[float, float]]] | None:
    """Where the emulated head truly looks, as a camera's pose source; None without errors,
    where what the unit reports is the truth."""
    if not emulator.errors.enabled:
        return None

    async def pose() -> tuple[float, float]:
        return emulator.pointing()

    return pose


class EmulatedPtu(CommandedPtu):
    """The emulator called in-process: no bytes on a line, same command language."""

    def __init__(self, emulator: Ptu46Emulator | None = None) -> None:
        super().__init__()
        self.emulator = emulator or Ptu46Emulator()
        self._lock = asyncio.Lock()
        self._framer = LineFramer()

    @classmethod
    def from_url(cls, url: str) -> EmulatedPtu:
        """``emu://?model=D46-17&time_scale=10&pointing_error=0.3&backlash=0.1&error_seed=7``."""
        return cls(_emulator(parse_qs(urlsplit(url).query)))

    @property
    def true_pose(self) -> Callable[[], Awaitable[tuple[float, float]]] | None:
        """Where the head truly looks (pan, tilt degrees), for a simulated camera; None
        when the emulator plays no errors."""
        return _true_pose(self.emulator)

    async def open(self) -> None:
        self._state = LinkState.CONNECTING
        await self._initialise()
        self._state = LinkState.READY

    async def close(self) -> None:
        if self._state is LinkState.READY:
            await self.halt()
        self._state = LinkState.DISCONNECTED

    async def _request(
        self,
        command: str,
        value: int | None = None,
        *,
        numeric: bool = False,
        timeout: float | None = None,
    ) -> Reply:
        if self._state is LinkState.DISCONNECTED:
            raise PtuConnectionError("emulated PTU is closed")
        data = format_command(command, value)
        sent = data.decode().strip()
        async with self._lock:
            lines = self._framer.feed(self.emulator.receive(data))
            try:
                async with asyncio.timeout(timeout or (120.0 if self.emulator.busy else 1.0)):
                    while True:
                        for line in lines:
                            reply = match_reply(line, sent, numeric)
                            if reply:
                                return reply
                        await asyncio.sleep(_POLL)
                        lines = self._framer.feed(self.emulator.poll())
            except TimeoutError:
                raise PtuTimeoutError(f"emulated PTU: no reply to {sent}") from None


class PtyPtu(SerialPtu):
    """The emulator on a pty in this process, driven through the real serial driver.

    ``server`` is exposed so tests and the demo can inject faults or hang the line up.
    """

    def __init__(
        self,
        emulator: Ptu46Emulator | None = None,
        *,
        faults: list[Fault] | None = None,
        banner: bytes | None = None,
        baud: int = 9600,
        **serial_options: object,
    ) -> None:
        self._dir = tempfile.TemporaryDirectory(prefix="cyborg-ptu-")
        link = Path(self._dir.name) / "ptu"
        self.server = PtyEmulatorServer(
            emulator or Ptu46Emulator(), link=link, faults=faults, banner=banner, baud=baud
        )
        super().__init__(str(link), **serial_options)  # type: ignore[arg-type]

    @classmethod
    def from_url(cls, url: str) -> PtyPtu:
        """``pty://?model=D46-17&time_scale=10``, also ``fault=drop:PP:2`` (repeatable, see
        :func:`~daemon.ptu.ptyserver.parse_fault`), ``banner=1`` and ``baud=0`` (no pacing;
        default 9600 like the real line)."""
        query = parse_qs(urlsplit(url).query)
        faults = [parse_fault(spec) for spec in query.get("fault", [])]
        banner = BANNER if query.get("banner", ["0"])[-1] not in ("0", "") else None
        baud = int(query.get("baud", ["9600"])[-1])
        return cls(_emulator(query), faults=faults, banner=banner, baud=baud)

    @property
    def true_pose(self) -> Callable[[], Awaitable[tuple[float, float]]] | None:
        """As :attr:`EmulatedPtu.true_pose`."""
        return _true_pose(self.server.emulator)

    async def open(self) -> None:
        if not self.server.connected:
            await self.server.start()
        try:
            await super().open()
        except BaseException:
            await self.server.close()
            raise

    async def close(self) -> None:
        try:
            await super().close()
        finally:
            await self.server.close()
            self._dir.cleanup()


class TcpPtu(PtyPtu):
    """The emulator on a pty behind a TCP line server: the real driver over ``socket://``,
    as a PTU-E46 or a terminal server would be reached."""

    def __init__(self, emulator: Ptu46Emulator | None = None, **options: object) -> None:
        super().__init__(emulator, **options)  # type: ignore[arg-type]
        self.line = TcpLineServer(str(self.server.link))

    async def open(self) -> None:
        if not self.server.connected:
            await self.server.start()
        await self.line.start()
        self.port = f"socket://127.0.0.1:{self.line.port}"
        await super().open()

    async def close(self) -> None:
        try:
            await super().close()
        finally:
            await self.line.close()
