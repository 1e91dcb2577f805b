"""Errors raised by pan-tilt units.

::

    PtuError                    root: anything that went wrong talking to a PTU
    ├── PtuConnectionError      the link is down (unplugged, port missing, hung up)
    ├── PtuTimeoutError         no reply in time, after any retries; the line was resynchronised
    ├── PtuProtocolError        a reply that cannot be understood (no number in it, a position
    │                           outside the limits the unit reported), even when asked again
    └── PtuCommandError         the unit answered ``! message``; nothing was executed
        ├── PtuLimitError       position outside the soft limits (also raised before sending)
        ├── PtuSpeedError       speed or acceleration outside the unit's bounds
        └── PtuIllegalCommandError   the unit does not know the command

Bad arguments (NaN angles, unknown axes) raise ``ValueError``.
"""

from __future__ import annotations

__all__ = [
    "PtuCommandError",
    "PtuConnectionError",
    "PtuError",
    "PtuIllegalCommandError",
    "PtuLimitError",
    "PtuProtocolError",
    "PtuSpeedError",
    "PtuTimeoutError",
    "command_error",
]


class PtuError(Exception):
    """Root of every pan-tilt unit error."""


class PtuConnectionError(PtuError):
    """The serial link is not usable; the driver reconnects on its own."""


class PtuTimeoutError(PtuError):
    """The unit did not answer in time (retry-safe commands were sent again first)."""


class PtuProtocolError(PtuError):
    """The unit answered something the driver cannot interpret or believe."""


class PtuCommandError(PtuError):
    """The unit refused a command with ``! message``; ``message`` is its own wording."""

    def __init__(self, command: str, message: str) -> None:
        super().__init__(f"{command}: {message}")
        self.command = command
        self.message = message


class PtuLimitError(PtuCommandError):
    """A position outside the unit's limits."""


class PtuSpeedError(PtuCommandError):
    """A speed or acceleration outside the unit's bounds."""


class PtuIllegalCommandError(PtuCommandError):
    """A command the unit does not understand."""


def command_error(command: str, message: str) -> PtuCommandError:
    """Classify a ``!`` reply by keywords, never by whole sentences (firmware wording varies)."""
    text = message.lower()
    if "illegal" in text or "unknown" in text:
        return PtuIllegalCommandError(command, message)
    if "speed" in text or "accel" in text:
        return PtuSpeedError(command, message)
    if "position" in text or "limit" in text:
        return PtuLimitError(command, message)
    return PtuCommandError(command, message)
