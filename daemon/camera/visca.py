"""Zoom over VISCA: the serial protocol of Sony's block cameras (FCB, EVI) and of most zoom
cameras sold to sit on a pan-tilt unit. The subset a rig needs, a driver, and an emulator
of that subset on a pty so the driver is tested the way the PTU's is.

Packets are ``8x ... FF`` from the host (x = camera address 1..7) and ``y0 ... FF`` back
(y = address + 8): an ACK ``y0 4s FF`` (s = socket), then a completion ``y0 5s FF``, or an
error ``y0 6s EE FF`` (02 syntax, 03 buffer full, 04 cancelled, 05 no socket, 41 not
executable now). Used here:

* ``8x 01 04 47 0p 0q 0r 0s FF``: CAM_Zoom Direct to position pqrs (0 = wide);
* ``8x 09 04 47 FF``: CAM_ZoomPosInq, answered ``y0 50 0p 0q 0r 0s FF``;
* ``88 30 01 FF``: AddressSet (broadcast), answered ``88 30 02 FF`` by a single camera.

Position and magnification: an FCB-style optical zoom spreads its positions roughly evenly
in log-magnification, so magnification = ``max_level ** (position / max_position)``; the
lens table of a given model can replace this. The seed's Sony camcorder took LANC instead
(a one-wire 9600-baud bus); a LANC back end would be another :class:`Zoom` whose
``set_level`` sends the zoom-tele/-wide commands and times the run, the rest unchanged.
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import os
import time
import tty
from abc import ABC, abstractmethod
from urllib.parse import parse_qs, urlsplit

import serial
import serial_asyncio_fast

__all__ = [
    "ViscaEmulator",
    "ViscaError",
    "ViscaZoom",
    "Zoom",
    "decode_position",
    "zoom_direct",
]

POSITION_INQUIRY = bytes.fromhex("81090447FF")
ADDRESS_SET = bytes.fromhex("883001FF")
_ERRORS = {
    0x01: "message length error",
    0x02: "syntax error",
    0x03: "command buffer full",
    0x04: "command cancelled",
    0x05: "no socket",
    0x41: "command not executable now",
}


class ViscaError(Exception):
    """The camera refused or did not answer; the text says which."""


class Zoom(ABC):
    """A zoom lens: a magnification from 1 (widest) to ``max_level``, and how long it took."""

    max_level: float = 1.0

    @abstractmethod
    async def set_level(self, level: float) -> float:
        """Zoom to ``level`` (clipped to 1..max_level); returns the seconds it took."""

    @abstractmethod
    async def level(self) -> float:
        """The magnification now."""


def zoom_direct(position: int, address: int = 1) -> bytes:
    """CAM_Zoom Direct.

    >>> zoom_direct(0x1234).hex()
    '8101044701020304ff'
    """
    if not 0 <= position <= 0xFFFF:
        raise ValueError(f"zoom position {position} outside 0..0xFFFF")
    nibbles = [(position >> shift) & 0xF for shift in (12, 8, 4, 0)]
    return bytes([0x80 | address, 0x01, 0x04, 0x47, *nibbles, 0xFF])


def decode_position(packet: bytes) -> int:
    """The position in a CAM_ZoomPosInq answer ``y0 50 0p 0q 0r 0s FF``.

    >>> decode_position(bytes.fromhex("905001020304ff"))
    4660
    """
    if len(packet) != 7 or packet[1] != 0x50 or packet[-1] != 0xFF:
        raise ViscaError(f"not a zoom position answer: {packet.hex(' ')}")
    return (packet[2] << 12) | (packet[3] << 8) | (packet[4] << 4) | packet[5]


class ViscaZoom(Zoom):
    """A VISCA camera's zoom on a serial port (9600 8N1 by default), one command at a time."""

    def __init__(
        self,
        port: str,
        *,
        max_level: float = 30.0,
        max_position: int = 0x4000,
        baudrate: int = 9600,
        timeout: float = 10.0,
    ) -> None:
        self.port, self.baudrate, self.timeout = port, baudrate, timeout
        self.max_level, self.max_position = max_level, max_position
        self._reader: asyncio.StreamReader | None = None
        self._writer: asyncio.StreamWriter | None = None
        self._lock = asyncio.Lock()

    @classmethod
    def from_url(cls, url: str) -> ViscaZoom:
        """``visca:///dev/ttyUSB1?max=30&baud=9600``: the port, the lens's longest zoom.

        >>> ViscaZoom.from_url("visca:///dev/ttyUSB1?max=20").max_level
        20.0
        """
        parts = urlsplit(url)
        if parts.scheme != "visca" or not parts.path:
            raise ValueError(f"zoom {url!r}: want visca:///dev/ttyUSB1?max=30")
        query = parse_qs(parts.query)
        return cls(
            parts.path,
            max_level=float(query.get("max", ["30"])[-1]),
            baudrate=int(query.get("baud", ["9600"])[-1]),
        )

    async def open(self) -> None:
        try:
            self._reader, self._writer = await serial_asyncio_fast.open_serial_connection(
                url=self.port, baudrate=self.baudrate
            )
        except (OSError, serial.SerialException) as exc:
            raise ViscaError(f"cannot open {self.port}: {exc}") from exc
        reply = await self._exchange(ADDRESS_SET, final=lambda p: p[:2] == b"\x88\x30")
        if reply != bytes.fromhex("883002FF"):
            raise ViscaError(f"{self.port}: unexpected AddressSet answer {reply.hex(' ')}")

    async def close(self) -> None:
        if self._writer is not None:
            self._writer.close()
            with contextlib.suppress(Exception):
                await self._writer.wait_closed()
            self._writer = self._reader = None

    def position_of(self, level: float) -> int:
        level = min(max(level, 1.0), self.max_level)
        return round(self.max_position * math.log(level) / math.log(self.max_level))

    def level_of(self, position: int) -> float:
        return float(
            self.max_level ** (min(max(position, 0), self.max_position) / self.max_position)
        )

    async def set_level(self, level: float) -> float:
        t0 = time.monotonic()
        await self._exchange(zoom_direct(self.position_of(level)), final=_completion)
        return time.monotonic() - t0

    async def level(self) -> float:
        reply = await self._exchange(POSITION_INQUIRY, final=lambda p: p[1:2] == b"\x50")
        return self.level_of(decode_position(reply))

    async def _exchange(self, packet: bytes, final) -> bytes:
        """Send ``packet``; skip ACKs until the packet ``final`` accepts; an error packet
        raises ViscaError with its meaning."""
        if self._reader is None or self._writer is None:
            raise ViscaError("the VISCA port is not open")
        async with self._lock:
            self._writer.write(packet)
            await self._writer.drain()
            try:
                async with asyncio.timeout(self.timeout):
                    while True:
                        reply = await self._reader.readuntil(b"\xff")
                        if len(reply) >= 3 and reply[1] & 0xF0 == 0x60:
                            code = reply[2] if len(reply) > 3 else 0
                            raise ViscaError(
                                f"camera: {_ERRORS.get(code, f'error {code:#04x}')} "
                                f"(to {packet.hex(' ')})"
                            )
                        if final(reply):
                            return reply
            except TimeoutError:
                raise ViscaError(f"no answer to {packet.hex(' ')} in {self.timeout:g} s") from None
            except asyncio.IncompleteReadError:
                raise ViscaError(f"{self.port} closed") from None


def _completion(packet: bytes) -> bool:
    return len(packet) == 3 and packet[1] & 0xF0 == 0x50


class ViscaEmulator:
    """The subset above, on a pty, with a lens that takes ``full_travel`` seconds from
    wide to tele. ``path`` is what the driver opens."""

    def __init__(self, full_travel: float = 2.0, max_position: int = 0x4000) -> None:
        self.full_travel, self.max_position = full_travel, max_position
        self.position = 0
        self.path = ""
        self._master = -1
        self._slave = -1
        self._buffer = bytearray()
        self._moving: asyncio.Task[None] | None = None

    async def start(self) -> ViscaEmulator:
        master, slave = os.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        self._master, self._slave, self.path = master, slave, os.ttyname(slave)
        asyncio.get_running_loop().add_reader(master, self._readable)
        return self

    async def close(self) -> None:
        if self._moving is not None:
            self._moving.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await self._moving
        if self._master >= 0:
            asyncio.get_running_loop().remove_reader(self._master)
            for fd in (self._master, self._slave):
                with contextlib.suppress(OSError):
                    os.close(fd)
            self._master = self._slave = -1

    def _readable(self) -> None:
        with contextlib.suppress(BlockingIOError, OSError):
            self._buffer += os.read(self._master, 256)
        while b"\xff" in self._buffer:
            end = self._buffer.index(b"\xff") + 1
            packet, self._buffer = bytes(self._buffer[:end]), self._buffer[end:]
            self._packet(packet)

    def _send(self, packet: bytes) -> None:
        with contextlib.suppress(OSError):
            os.write(self._master, packet)

    def _packet(self, p: bytes) -> None:
        if p == ADDRESS_SET:
            self._send(bytes.fromhex("883002FF"))
        elif len(p) == 5 and p[0] == 0x81 and p[1:4] == b"\x09\x04\x47":
            pos = self.position
            self._send(bytes([0x90, 0x50, *[(pos >> s) & 0xF for s in (12, 8, 4, 0)], 0xFF]))
        elif (
            len(p) == 9
            and p[0] == 0x81
            and p[1:4] == b"\x01\x04\x47"
            and all(b <= 0xF for b in p[4:8])
        ):
            if self._moving is not None and not self._moving.done():
                self._send(bytes.fromhex("906241FF"))  # busy: not executable now
                return
            target = (p[4] << 12) | (p[5] << 8) | (p[6] << 4) | p[7]
            target = min(target, self.max_position)
            self._send(bytes.fromhex("9041FF"))
            self._moving = asyncio.get_running_loop().create_task(
                self._travel(target), name="cyborgd.visca-emulator.zoom"
            )
        else:
            self._send(bytes.fromhex("906002FF"))  # syntax error

    async def _travel(self, target: int) -> None:
        await asyncio.sleep(self.full_travel * abs(target - self.position) / self.max_position)
        self.position = target
        self._send(bytes.fromhex("9051FF"))
