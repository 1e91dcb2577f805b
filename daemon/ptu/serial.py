"""The PTU-46 serial driver over pyserial-asyncio-fast.

``pyserial-asyncio-fast`` is the maintained drop-in successor of ``pyserial-asyncio``
(same ``open_serial_connection`` API; it opens the port off the event loop).

One request is in flight at a time. Replies are matched to their command (by echo when
the unit echoes, by shape otherwise); banners, garbage and stale lines are skipped.

A reply lost to the line (noise glued onto it, dropped, or late) costs a retry, not a
station. Once a line that is not the reply has been seen, the reply gets a short grace
to follow it; after that, or after the full timeout, the driver resynchronises: it ends
any half-typed command and asks :data:`~daemon.ptu.wire.PROBE`, discarding every line up
to the answer, so no late reply is left to answer a later request. Then it sends the
command again if repeating it is harmless (queries, settings, absolute moves: see
:func:`~daemon.ptu.wire.retry_safe`), up to ``retries`` times, each logged. Relative moves
are never sent twice: a lost reply fails them with ``PtuTimeoutError``. A unit that
answers no probe is gone, and the request fails at once.

When the port goes away the driver marks itself DISCONNECTED, fails the pending request
with ``PtuConnectionError`` (never retried) and reconnects in the background with capped,
jittered backoff.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import random
from urllib.parse import parse_qs, urlsplit

import serial
import serial_asyncio_fast

from .base import LinkState
from .commanded import CommandedPtu
from .errors import PtuConnectionError, PtuError, PtuTimeoutError
from .wire import (
    DELIMITER,
    PROBE,
    LineFramer,
    Reply,
    answers_probe,
    format_command,
    match_reply,
    retry_safe,
    split_limit_events,
)

__all__ = ["SerialPtu"]

_LOGGER = logging.getLogger(__name__)

SETTLE = 0.15
"""Seconds to wait after the first bare delimiter at connect, for a banner to finish."""
GRACE = 0.2
"""Seconds a reply may still take once a line that is not it arrived (garbage on a line of
its own comes just before the reply; noise glued onto the reply means it will not come).
Ten times the longest terse reply at 9600 baud, twice a USB adapter's latency timer."""
PROBES = 3
"""Probes per resynchronisation: a unit that answers none is gone."""


class SerialPtu(CommandedPtu):
    """A PTU-46 on a serial port (a USB adapter, a pty, anything pyserial opens)."""

    def __init__(
        self,
        port: str,
        baudrate: int = 9600,
        *,
        command_timeout: float = 1.0,
        retries: int = 2,
        reconnect: bool = True,
        backoff: tuple[float, float] = (0.1, 5.0),
    ) -> None:
        """``retries``: extra attempts for a retry-safe command whose reply was lost."""
        super().__init__()
        self.port = port
        self.baudrate = baudrate
        self.command_timeout = command_timeout
        self.retries = retries
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
        self.retried = 0
        """Commands sent again after a lost reply (each one logged)."""

    @classmethod
    def from_url(cls, url: str) -> SerialPtu:
        """``serial:///dev/ttyUSB0?baud=9600`` or a bare path; ``tcp://host:port`` (a PTU-E46
        or a terminal server, pyserial's ``socket://``); ``socket://`` and ``rfc2217://`` as
        pyserial takes them.

        >>> SerialPtu.from_url("/dev/ttyUSB0").port, SerialPtu.from_url("tcp://ts:4000").port
        ('/dev/ttyUSB0', 'socket://ts:4000')
        """
        parts = urlsplit(url)
        if parts.scheme == "tcp":
            if not parts.port:
                raise ValueError(f"no host:port in {url!r}")
            return cls(f"socket://{parts.netloc}")
        port = url if parts.scheme in ("", "socket", "rfc2217") else parts.path
        if not port:
            raise ValueError(f"no serial port in {url!r}")
        return cls(port, int(parse_qs(parts.query).get("baud", ["9600"])[-1]))

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
                _LOGGER.warning("could not halt the PTU before closing: %s", exc or "no answer")
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

    def _stray(self, line: str) -> bool:
        """A line nobody asked for: report limit events, log the rest; True if there was a
        rest (something that may have been a reply)."""
        rest, events = split_limit_events(line)
        for axis in events:
            self._limit_event(axis)
        if rest:
            _LOGGER.debug("PTU: ignored %r", line)
        return bool(rest)

    async def _line(self, during: str) -> str:
        line = await self._lines.get()
        if line is None:
            self._lines.put_nowait(None)
            raise PtuConnectionError(f"PTU on {self.port} went away during {during}")
        return line

    async def _resync(self) -> bool:
        async with self._lock:
            return await self._realign()

    async def _realign(self) -> bool:
        """End any half-typed command, then ask the probe and discard every line up to its
        answer: whatever the unit still owed has arrived by then. False if it answered no
        probe (a late answer to an earlier probe counts: it comes after the same lines)."""
        self.resyncs += 1
        probe = DELIMITER + format_command(PROBE)
        for _ in range(PROBES):
            await self._write(probe)
            try:
                async with asyncio.timeout(self.command_timeout):
                    while not answers_probe(line := await self._line("a resync")):
                        self._stray(line)
                return True
            except TimeoutError:
                continue
        return False

    async def _request(
        self,
        command: str,
        value: int | None = None,
        *,
        numeric: bool = False,
        timeout: float | None = None,
    ) -> Reply:
        """Send, await the reply; a lost reply is retried only if :func:`retry_safe`
        (never a relative move). ``PtuConnectionError`` is never retried."""
        if self._state not in (LinkState.READY, LinkState.CONNECTING):
            raise PtuConnectionError(f"PTU on {self.port} is {self._state.value}")
        data = format_command(command, value)
        sent = data.decode().strip()
        retries = self.retries if retry_safe(command, value) else 0
        async with self._lock:
            for attempt in itertools.count(1):
                try:
                    reply = await self._exchange(
                        data, sent, numeric, timeout or self.command_timeout, retries > 0
                    )
                    break
                except PtuTimeoutError as exc:
                    if not await self._realign():
                        raise PtuTimeoutError(f"{exc}; the unit answers nothing") from None
                    if attempt > retries:
                        raise
                    self.retried += 1
                    _LOGGER.warning(
                        "%s; line resynchronised, sending it again (%d of %d)",
                        exc,
                        attempt,
                        retries,
                    )
        if command != "R":
            for axis in reply.limit_events:
                self._limit_event(axis)
        return reply

    async def _exchange(
        self, data: bytes, sent: str, numeric: bool, timeout: float, hurry: bool
    ) -> Reply:
        """One attempt. ``hurry``: after a line that is not the reply, wait only
        :data:`GRACE` more (it can be retried, so a lost reply need not cost the timeout)."""
        self._flush()
        await self._write(data)
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        garbled = False
        try:
            async with asyncio.timeout_at(deadline) as scope:
                while True:
                    line = await self._line(sent)
                    reply = match_reply(line, sent, numeric)
                    if reply is not None:
                        return reply
                    if self._stray(line) and hurry:
                        garbled = True
                        scope.reschedule(min(deadline, loop.time() + GRACE))
        except TimeoutError:
            what = "no readable reply" if garbled else "no reply"
            raise PtuTimeoutError(f"PTU on {self.port}: {what} to {sent}") from None
