"""Errors decoding what arrives on the bus.

::

    ProtocolError           root: the input never reaches the hardware
    ├── DecodeError         not msgpack, not a map, too large, too deep, a missing field
    ├── VersionError        another protocol major
    └── InvalidFieldError   a field of the wrong type or out of range
"""

from __future__ import annotations

__all__ = ["DecodeError", "InvalidFieldError", "ProtocolError", "VersionError"]


class ProtocolError(ValueError):
    """Root of every protocol error; the text is safe to send back in an Ack."""


class DecodeError(ProtocolError):
    pass


class VersionError(ProtocolError):
    pass


class InvalidFieldError(ProtocolError):
    pass
