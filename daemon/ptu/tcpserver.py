"""A serial line served over TCP, as a terminal server (ser2net, a Moxa NPort) or a
PTU-E46's Ethernet port serves the PTU's ASCII protocol: ``tcp://host:port`` then reaches
it through pyserial's ``socket://`` handler, with the same driver.

One client at a time, as a serial line has one end; a second is turned away. When the
device goes away (a hang-up), the client's connection is closed too, and the next client
opens the device afresh. Used to serve the emulator's pty over TCP (tests, ``cyborgd
ptu-emulator --tcp``); hand-written because it is forty lines of asyncio, where ser2net
would be a system package and a config file.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging

import serial
import serial_asyncio_fast

__all__ = ["TcpLineServer"]

_LOGGER = logging.getLogger(__name__)


class TcpLineServer:
    """Serve the serial device ``device`` on ``host:port`` (port 0: any free one)."""

    def __init__(self, device: str, host: str = "127.0.0.1", port: int = 0) -> None:
        self.device, self.host, self.port = device, host, port
        self._server: asyncio.Server | None = None
        self._busy = False
        self._tasks: set[asyncio.Task[None]] = set()

    @property
    def url(self) -> str:
        return f"tcp://{self.host}:{self.port}"

    async def start(self) -> TcpLineServer:
        self._server = await asyncio.start_server(self._client, self.host, self.port)
        self.port = self._server.sockets[0].getsockname()[1]
        return self

    async def close(self) -> None:
        if self._server is not None:
            self._server.close()
            for task in list(self._tasks):
                task.cancel()
            await asyncio.gather(*self._tasks, return_exceptions=True)
            await self._server.wait_closed()
            self._server = None

    async def _client(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        if self._busy:
            writer.close()
            return
        self._busy = True
        try:
            line_r, line_w = await serial_asyncio_fast.open_serial_connection(
                url=self.device, baudrate=9600
            )
        except (OSError, serial.SerialException) as exc:
            _LOGGER.warning("%s: cannot open %s: %s", self.url, self.device, exc)
            self._busy = False
            writer.close()
            return
        pumps = [
            asyncio.create_task(_pump(reader, line_w), name="cyborgd.tcpline.in"),
            asyncio.create_task(_pump(line_r, writer), name="cyborgd.tcpline.out"),
        ]
        self._tasks.update(pumps)
        try:
            await asyncio.wait(pumps, return_when=asyncio.FIRST_COMPLETED)
        finally:
            for task in pumps:
                task.cancel()
            await asyncio.gather(*pumps, return_exceptions=True)
            self._tasks.difference_update(pumps)
            for w in (writer, line_w):
                w.close()
                with contextlib.suppress(Exception):
                    await w.wait_closed()
            self._busy = False


async def _pump(source: asyncio.StreamReader, sink: asyncio.StreamWriter) -> None:
    with contextlib.suppress(OSError, serial.SerialException):
        while data := await source.read(4096):
            sink.write(data)
            await sink.drain()
