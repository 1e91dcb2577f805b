"""The PTU-46 serial driver over pyserial-asyncio-fast.

``pyserial-asyncio-fast`` is the maintained drop-in successor of ``pyserial-asyncio``
(same ``open_serial_connection`` API; it opens the port off the event loop).

One request is in flight at a time. Replies are matched to their command (by echo when
the unit echoes, by shape otherwise); banners, garbage and stale lines are skipped, and
after a timeout the driver resynchronises (a bare delimiter, a pause, a flush). When the
port goes away the driver marks itself DISCONNECTED, fails the pending request with
``PtuConnectionError`` and reconnects in the background with capped, jittered backoff.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import random

import serial
import serial_asyncio_fast

from .base import LinkState
from .commanded import CommandedPtu
from .errors import PtuConnectionError, PtuError, PtuTimeoutError
from .wire import (
    DELIMITER,
    LineFramer,
    Reply,
    format_command,
    match_reply,
    split_limit_events,
)

__all__ = ["SerialPtu"]

_LOGGER = logging.getLogger(__name__)

SETTLE = 0.15
"""Seconds to wait after a bare delimiter before flushing (connect and resync)."""


class SerialPtu(CommandedPtu):
    """A PTU-46 on a serial port (a USB adapter, a pty, anything pyserial opens)."""

    def __init__(
        self,
        port: str,
        baudrate: int = 9600,
        *,
        command_timeout: float = 1.0,
        reconnect: bool = True,
        backoff: tuple[float, float] = (0.1, 5.0),
    ) -> None:
        super().__init__()
        self.port = port
        self.baudrate = baudrate
        self.command_timeout = command_timeout
        self.reconnect = reconnect
        self.backoff = backoff
        self._lock = asyncio.Lock()
        self._lines: asyncio.Queue[str | None] = asyncio.Queue()
        self._writer: asyncio.StreamWriter | None = None
        self._reader_task: asyncio.Task[None] | None = None
        self._reconnect_task: asyncio.Task[None] | None = None
        self._closing = False
        self.reconnects = 0
        self.resyncs = 0

    # -- lifecycle -----------------------------------------------------------------------

    async def open(self) -> None:
        """Connect and initialise once; raises ``PtuConnectionError`` if that fails."""
        self._closing = False
        await self._connect()

    async def close(self) -> None:
        self._closing = True
        if self._reconnect_task:
            self._reconnect_task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._reconnect_task
            self._reconnect_task = None
        if self._state is LinkState.READY:
            try:
                await asyncio.wait_for(self.halt(), 1.0)
            except (PtuError, TimeoutError) as exc:
                _LOGGER.warning("could not halt the PTU before closing: %s", exc)
        await self._drop_link()
        self._state = LinkState.DISCONNECTED

    async def _connect(self) -> None:
        self._state = LinkState.CONNECTING
        try:
            reader, writer = await serial_asyncio_fast.open_serial_connection(
                url=self.port,
                baudrate=self.baudrate,
                bytesize=8,
                parity="N",
                stopbits=1,
                xonxoff=False,
                rtscts=False,
                dsrdtr=False,
            )
        except (OSError, serial.SerialException) as exc:
            self._state = LinkState.DISCONNECTED
            raise PtuConnectionError(f"cannot open {self.port}: {exc}") from exc
        self._writer = writer
        self._lines = asyncio.Queue()
        self._reader_task = asyncio.create_task(self._read(reader), name="cyborgd.ptu.read")
        try:
            # End any half-typed command, let a banner finish, then start clean.
            await self._write(DELIMITER)
            await asyncio.sleep(SETTLE)
            self._flush()
            await self._initialise()
        except (PtuError, OSError) as exc:
            await self._drop_link()
            self._state = LinkState.DISCONNECTED
            if isinstance(exc, PtuConnectionError):
                raise
            raise PtuConnectionError(f"{self.port}: unit did not initialise: {exc}") from exc
        self._state = LinkState.READY

    async def _drop_link(self) -> None:
        task, self._reader_task = self._reader_task, None
        if task and task is not asyncio.current_task():
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task
        writer, self._writer = self._writer, None
        if writer:
            writer.close()
            with contextlib.suppress(Exception):
                await writer.wait_closed()

    def _lost(self, why: str) -> None:
        """Called from the reader when the port vanishes."""
        if self._closing or self._state is LinkState.DISCONNECTED:
            return
        _LOGGER.warning("PTU link on %s lost: %s", self.port, why)
        self._state = LinkState.DISCONNECTED
        self._lines.put_nowait(None)
        if self.reconnect and not self._reconnect_task:
            self._reconnect_task = asyncio.create_task(
                self._reconnect_loop(), name="cyborgd.ptu.reconnect"
            )

    async def _reconnect_loop(self) -> None:
        delay, cap = self.backoff
        attempt = 0
        try:
            await self._drop_link()
            while not self._closing:
                await asyncio.sleep(delay * random.uniform(0.8, 1.2))
                attempt += 1
                try:
                    await self._connect()
                except PtuConnectionError as exc:
                    log = _LOGGER.warning if attempt == 1 else _LOGGER.debug
                    log("PTU reconnect attempt %d failed: %s", attempt, exc)
                    delay = min(delay * 2, cap)
                    continue
                self.reconnects += 1
                _LOGGER.warning("PTU on %s reconnected after %d attempt(s)", self.port, attempt)
                return
        finally:
            self._reconnect_task = None

    async def wait_ready(self, timeout: float) -> None:
        """Wait until the link is READY again (after a reconnect)."""
        async with asyncio.timeout(timeout):
            while self._state is not LinkState.READY:
                await asyncio.sleep(0.02)

    # -- byte path -----------------------------------------------------------------------

    async def _read(self, reader: asyncio.StreamReader) -> None:
        framer = LineFramer()
        try:
            while True:
                data = await reader.read(256)
                if not data:
                    self._lost("end of file")
                    return
                for line in framer.feed(data):
                    self._lines.put_nowait(line)
        except (OSError, serial.SerialException) as exc:
            self._lost(str(exc))

    async def _write(self, data: bytes) -> None:
        if self._writer is None:
            raise PtuConnectionError(f"{self.port}: not connected")
        self._writer.write(data)
        try:
            await self._writer.drain()
        except (OSError, serial.SerialException) as exc:
            self._lost(str(exc))
            raise PtuConnectionError(f"{self.port}: write failed: {exc}") from exc

    def _flush(self) -> None:
        while not self._lines.empty():
            line = self._lines.get_nowait()
            if line is None:
                self._lines.put_nowait(None)
                return
            self._stray(line)

    def _stray(self, line: str) -> None:
        """A line nobody asked for: report limit events, log the rest."""
        rest, events = split_limit_events(line)
        for axis in events:
            self._limit_event(axis)
        if rest:
            _LOGGER.debug("PTU: ignored %r", line)

    async def _resync(self) -> None:
        self.resyncs += 1
        with contextlib.suppress(PtuConnectionError):
            await self._write(DELIMITER)
        await asyncio.sleep(SETTLE)
        self._flush()

    async def _request(
        self,
        command: str,
        value: int | None = None,
        *,
        numeric: bool = False,
        timeout: float | None = None,
    ) -> Reply:
        if self._state not in (LinkState.READY, LinkState.CONNECTING):
            raise PtuConnectionError(f"PTU on {self.port} is {self._state.value}")
        data = format_command(command, value)
        sent = data.decode().strip()
        async with self._lock:
            self._flush()
            await self._write(data)
            try:
                async with asyncio.timeout(timeout or self.command_timeout):
                    while True:
                        line = await self._lines.get()
                        if line is None:
                            self._lines.put_nowait(None)
                            raise PtuConnectionError(f"PTU on {self.port} went away during {sent}")
                        reply = match_reply(line, sent, numeric)
                        if reply is None:
                            self._stray(line)
                            continue
                        if command != "R":
                            for axis in reply.limit_events:
                                self._limit_event(axis)
                        return reply
            except TimeoutError:
                await self._resync()
                raise PtuTimeoutError(f"PTU on {self.port}: no reply to {sent}") from None
