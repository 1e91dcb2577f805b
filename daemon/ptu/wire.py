"""The PTU-46 ASCII line codec, pure: bytes in, typed replies out.

A command is letters plus an optional signed integer, ended by a space (the unit also
takes CR). Every reply line ends in CR LF and its first character after the echo is
``*`` (success, maybe followed by a value or a sentence) or ``!`` (refused, followed by
the unit's message). With echo on, the line starts with the command as typed. ``!P`` and
``!T`` tokens are limit events that can appear anywhere, unsolicited. Numbers are taken
from the text by pattern, never by matching whole sentences, because wording differs
between firmware versions and between verbose and terse feedback.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = [
    "DELIMITER",
    "LineFramer",
    "Reply",
    "format_command",
    "match_reply",
    "parse_reply",
    "reply_float",
    "reply_int",
    "split_limit_events",
]

DELIMITER = b" "
_COMMAND = re.compile(r"[A-Z@_]{1,4}\Z")
_LIMIT_EVENT = re.compile(r"!([PT])(?=[!*\s]|$)")
_NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?")
_UNIT_VALUE = re.compile(r"\bis\s+([-+]?\d+(?:\.\d+)?)", re.IGNORECASE)
MAX_LINE = 512
"""Longer lines are garbage by definition (the longest D46 reply is the version banner)."""


def format_command(command: str, value: int | None = None) -> bytes:
    """Encode one command with its delimiter.

    >>> format_command("pp", -500), format_command("A")
    (b'PP-500 ', b'A ')
    """
    name = command.upper()
    if not _COMMAND.match(name):
        raise ValueError(f"not a PTU command: {command!r}")
    if value is None:
        return name.encode("ascii") + DELIMITER
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError(f"PTU arguments are integers, got {value!r}")
    return f"{name}{value}".encode("ascii") + DELIMITER


@dataclass(frozen=True)
class Reply:
    """One parsed reply line."""

    ok: bool
    """``*`` (True) or ``!`` (False)."""
    text: str
    """What follows the status character, stripped: a value, a sentence or an error message."""
    limit_events: tuple[str, ...] = ()
    """Axes (``"P"``/``"T"``) that reported hitting a limit in this line."""
    echo: str | None = None
    """The echoed command, when the unit echoes."""


def split_limit_events(line: str) -> tuple[str, tuple[str, ...]]:
    """Remove ``!P``/``!T`` limit events from a line; return the rest and the axes.

    >>> split_limit_events("!P")
    ('', ('P',))
    """
    events: list[str] = []

    def take(m: re.Match[str]) -> str:
        events.append(m.group(1))
        return ""

    return _LIMIT_EVENT.sub(take, line).strip(), tuple(events)


def parse_reply(line: str, sent: str | None = None) -> Reply | None:
    """Parse one line (without CR LF); ``None`` if it is not a reply to ``sent``.

    ``sent`` is the command as written, without delimiter. A line echoing a *different*
    command is stale and yields ``None``, so a leftover ``PP1000 *`` cannot answer a ``PP``
    query. Lines that are neither ``*`` nor ``!`` (banners, garbage) and lines holding only
    unsolicited limit events also yield ``None``.

    >>> parse_reply("PP * Current Pan position is -500", "PP")
    Reply(ok=True, text='Current Pan position is -500', limit_events=(), echo='PP')
    >>> parse_reply("* 22", "PP").text, parse_reply("PP1000 *", "PP") is None
    ('22', True)
    >>> parse_reply("! Maximum allowable Pan position is 3090", "PP4000").ok
    False
    >>> parse_reply("R !T!T!P!P*", "R").limit_events
    ('T', 'T', 'P', 'P')
    """
    line = line.strip()
    if not line or len(line) > MAX_LINE:
        return None
    echo = None
    if line[0] not in "*!":
        head, _, rest = line.partition(" ")
        if sent is None or head.upper() != sent.upper():
            return None
        echo, line = head, rest.strip()
    line, events = split_limit_events(line)
    if not line:
        return None
    if line[0] == "*":
        return Reply(True, line[1:].strip(), events, echo)
    if line[0] == "!":
        return Reply(False, line[1:].strip(), events, echo)
    return None


def match_reply(line: str, sent: str, numeric: bool = False) -> Reply | None:
    """The reply to ``sent`` in ``line``, or ``None`` if the line answers something else.

    ``numeric``: ``sent`` is a query, so a success without a number is stale, not its answer.

    >>> match_reply("*", "PP", numeric=True) is None, match_reply("* 5", "PP", numeric=True).text
    (True, '5')
    """
    reply = parse_reply(line, sent)
    if reply is None or (numeric and reply.ok and reply_float(reply) is None):
        return None
    return reply


def reply_int(reply: Reply) -> int | None:
    """The integer value of a query reply, or ``None`` if it holds none.

    Speeds and accelerations end in a unit ("1000 positions/sec^2") so their value is
    the first number after "is"; otherwise it is the last number in the line.

    >>> reply_int(parse_reply("* Pan acceleration is 2000 positions/sec^2"))
    2000
    >>> reply_int(parse_reply("* Maximum Pan position is 3090")), reply_int(parse_reply("* -7"))
    (3090, -7)
    """
    value = reply_float(reply)
    return None if value is None else round(value)


def reply_float(reply: Reply) -> float | None:
    """The numeric value of a query reply (resolution is fractional).

    >>> reply_float(parse_reply("* 185.1428 seconds arc per Pan position"))
    185.1428
    """
    m = _UNIT_VALUE.search(reply.text)
    if m:
        return float(m.group(1))
    numbers = _NUMBER.findall(reply.text)
    if not numbers:
        return None
    # "185.1428 seconds arc per position": a value followed by words is the first number.
    first = _NUMBER.search(reply.text)
    assert first is not None
    if reply.text[first.end() :].strip()[:1].isalpha():
        return float(first.group())
    return float(numbers[-1])


class LineFramer:
    """Split a byte stream into lines on LF, dropping CR, NUL and over-long garbage.

    >>> f = LineFramer()
    >>> f.feed(b"PP * 1"), f.feed(b"2\\r\\n* \\r\\n")
    ([], ['PP * 12', '*'])
    """

    def __init__(self) -> None:
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[str]:
        self._buf += data
        lines: list[str] = []
        while True:
            i = self._buf.find(b"\n")
            if i < 0:
                if len(self._buf) > MAX_LINE:
                    del self._buf[:]
                return lines
            raw = bytes(self._buf[:i]).replace(b"\r", b"").replace(b"\0", b"")
            del self._buf[: i + 1]
            text = raw.decode("ascii", "replace").strip()
            if text:
                lines.append(text)

    def pending(self) -> str:
        """Bytes received after the last LF (an echo still waiting for its reply)."""
        return self._buf.decode("ascii", "replace")

    def clear(self) -> None:
        self._buf.clear()
