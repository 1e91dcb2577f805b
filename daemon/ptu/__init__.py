"""Pan-tilt units: one async interface, backends chosen by URL.

======================================  ===================================================
``serial:///dev/ttyUSB0?baud=9600``     a real PTU-46 on a serial port (or a bare path)
``tcp://10.0.0.7:4000``                 a PTU-E46 or a terminal server (``socket://``,
                                        ``rfc2217://`` as pyserial takes them)
``pty://?model=D46-17&time_scale=10``   the emulator on a pseudo-terminal, real serial driver
``emu://?model=D46-17&time_scale=10``   the emulator in-process, for fast logic tests
======================================  ===================================================

``pty://`` also takes ``fault=drop:PP:2`` (repeatable, see :func:`ptyserver.parse_fault`)
``banner=1`` and ``baud=0`` (no pacing; default 9600 like the real line).

A backend is a :class:`PanTiltUnit` with a ``from_url(url)`` class method, named by a row
of :data:`BACKENDS` and imported when a URL first asks for it: a new vendor is one module
and one row.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any
from urllib.parse import urlsplit

from .base import AxisInfo, LinkState, PanTiltUnit, PtuInfo, PtuPosition
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

if TYPE_CHECKING:
    from .emulated import EmulatedPtu, PtyPtu
    from .ptyserver import BANNER
    from .serial import SerialPtu

__all__ = [
    "BACKENDS",
    "BANNER",
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

BACKENDS: dict[str, str] = {
    "": ".serial:SerialPtu",
    "serial": ".serial:SerialPtu",
    "tcp": ".serial:SerialPtu",
    "socket": ".serial:SerialPtu",
    "rfc2217": ".serial:SerialPtu",
    "pty": ".emulated:PtyPtu",
    "emu": ".emulated:EmulatedPtu",
}
"""URL scheme -> ``module:class`` of its backend (relative to this package)."""

_LAZY = {
    "BANNER": ".ptyserver",
    "EmulatedPtu": ".emulated",
    "PtyPtu": ".emulated",
    "SerialPtu": ".serial",
}
"""Backends are imported when first used: a rig on a real unit never loads the emulator."""


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def open_ptu(url: str) -> PanTiltUnit:
    """Build (not open) the pan-tilt unit a URL names.

    >>> type(open_ptu("emu://?time_scale=50")).__name__, open_ptu("/dev/ttyUSB0").port
    ('EmulatedPtu', '/dev/ttyUSB0')
    >>> open_ptu("tcp://10.0.0.7:4000").port, open_ptu("rfc2217://ts:7001").port
    ('socket://10.0.0.7:4000', 'rfc2217://ts:7001')
    """
    scheme = urlsplit(url).scheme
    if scheme not in BACKENDS:
        raise ValueError(f"unknown PTU URL scheme {scheme!r} in {url!r}")
    module, _, name = BACKENDS[scheme].partition(":")
    backend = getattr(importlib.import_module(module, __name__), name)
    return backend.from_url(url)
