"""Pan-tilt units: one async interface, backends chosen by URL.

======================================  ===================================================
``serial:///dev/ttyUSB0?baud=9600``     a real PTU-46 on a serial port (or a bare path)
``pty://?model=D46-17&time_scale=10``   the emulator on a pseudo-terminal, real serial driver
``emu://?model=D46-17&time_scale=10``   the emulator in-process, for fast logic tests
======================================  ===================================================

``pty://`` also takes ``fault=drop:PP:2`` (repeatable, see :func:`ptyserver.parse_fault`)
``banner=1`` and ``baud=0`` (no pacing; default 9600 like the real line).
"""

from __future__ import annotations

from urllib.parse import parse_qs, urlsplit

from .base import AxisInfo, LinkState, PanTiltUnit, PtuInfo, PtuPosition
from .emulated import EmulatedPtu, PtyPtu
from .emulator import Ptu46Emulator
from .errors import (
    PtuCommandError,
    PtuConnectionError,
    PtuError,
    PtuIllegalCommandError,
    PtuLimitError,
    PtuProtocolError,
    PtuSpeedError,
    PtuTimeoutError,
)
from .models import MODELS
from .ptyserver import BANNER, parse_fault
from .serial import SerialPtu

__all__ = [
    "AxisInfo",
    "EmulatedPtu",
    "LinkState",
    "PanTiltUnit",
    "PtuCommandError",
    "PtuConnectionError",
    "PtuError",
    "PtuIllegalCommandError",
    "PtuInfo",
    "PtuLimitError",
    "PtuPosition",
    "PtuProtocolError",
    "PtuSpeedError",
    "PtuTimeoutError",
    "PtyPtu",
    "SerialPtu",
    "open_ptu",
]


def _emulator(query: dict[str, list[str]]) -> Ptu46Emulator:
    name = query.get("model", ["D46-17"])[-1]
    if name not in MODELS:
        raise ValueError(f"unknown PTU model {name!r}; known: {', '.join(MODELS)}")
    return Ptu46Emulator(MODELS[name], time_scale=float(query.get("time_scale", ["1"])[-1]))


def open_ptu(url: str) -> PanTiltUnit:
    """Build (not open) the pan-tilt unit a URL names.

    >>> type(open_ptu("emu://?time_scale=50")).__name__, open_ptu("/dev/ttyUSB0").port
    ('EmulatedPtu', '/dev/ttyUSB0')
    >>> open_ptu("tcp://10.0.0.7:4000").port, open_ptu("rfc2217://ts:7001").port
    ('socket://10.0.0.7:4000', 'rfc2217://ts:7001')
    """
    parts = urlsplit(url)
    query = parse_qs(parts.query)
    if parts.scheme in ("", "serial"):
        port = parts.path if parts.scheme else url
        if not port:
            raise ValueError(f"no serial port in {url!r}")
        return SerialPtu(port, int(query.get("baud", ["9600"])[-1]))
    if parts.scheme == "tcp":  # a PTU-E46 or a terminal server: pyserial's socket://
        if not parts.port:
            raise ValueError(f"no host:port in {url!r}")
        return SerialPtu(f"socket://{parts.netloc}")
    if parts.scheme in ("socket", "rfc2217"):
        return SerialPtu(url, int(query.get("baud", ["9600"])[-1]))
    if parts.scheme == "emu":
        return EmulatedPtu(_emulator(query))
    if parts.scheme == "pty":
        faults = [parse_fault(spec) for spec in query.get("fault", [])]
        banner = BANNER if query.get("banner", ["0"])[-1] not in ("0", "") else None
        baud = int(query.get("baud", ["9600"])[-1])
        return PtyPtu(_emulator(query), faults=faults, banner=banner, baud=baud)
    raise ValueError(f"unknown PTU URL scheme {parts.scheme!r} in {url!r}")
