"""The PTU-46 ASCII line codec, pure: bytes in, typed replies out.

A command is letters plus an optional signed integer, ended by a space (the unit also
takes CR). Every reply line ends in CR LF and its first character after the echo is
``*`` (success, maybe followed by a value or a sentence) or ``!`` (refused, followed by
the unit's message). With echo on, the line starts with the command as typed. ``!P`` and
``!T`` tokens are limit events that can appear anywhere, unsolicited. Numbers are taken
from the text by pattern, never by matching whole sentences, because wording differs
between firmware versions and between verbose and terse feedback.

Line noise is told from replies by shape: a reply is printable ASCII, a terse value is
a clean number, and a command carrying a value is answered by a bare ``*``. A line that
fails these is not a reply, whatever digits it holds, so a burst glued onto a reply
costs a retry, never a wrong number.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = [
    "DELIMITER",
    "PROBE",
    "LineFramer",
    "Reply",
    "answers_probe",
    "format_command",
    "match_reply",
    "parse_reply",
    "reply_float",
    "reply_int",
    "retry_safe",
    "split_limit_events",
]

DELIMITER = b" "
PROBE = "L"
"""The question a driver resynchronises with: harmless, always answered, and answered in
words (no number, not a bare ``*``), so its answer cannot pass for any other reply and
no other reply can pass for it."""
_COMMAND = re.compile(r"[A-Z@_]{1,4}\Z")
_WITH_VALUE = re.compile(r"[A-Z@_]+[-+]?\d+\Z", re.IGNORECASE)
_TERSE = re.compile(r"[-+]?\d+(?:\.\d+)?(?:\s*,\s*[-+]?\d+(?:\.\d+)?)*\Z")
_RELATIVE = frozenset({"PO", "TO", "PD", "TD"})
"""With a value these add to where the axis is (or to its speed): sent twice, done twice."""
_NOT_REPEATED = frozenset({"A", "R", "DS", "DR", "DF"})
"""``A`` waits for motion and ``R`` recalibrates (their silence is the head's, not the
line's); the ``D`` commands write or reload the EEPROM, which wears."""
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


def retry_safe(command: str, value: int | None = None) -> bool:
    """Whether sending ``command`` again, when its reply was lost, changes nothing more.

    Queries, settings and absolute moves are; relative moves (``PO``/``TO`` with a value)
    and speed offsets are not: the first copy may have been executed.

    >>> retry_safe("PP"), retry_safe("PP", 500), retry_safe("PO", 500), retry_safe("PO")
    (True, True, False, True)
    """
    name = command.upper()
    if value is not None and name in _RELATIVE:
        return False
    return name not in _NOT_REPEATED


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
    unsolicited limit events also yield ``None``, and so do lines with bytes no unit
    prints (control characters, anything beyond ASCII): line noise.

    >>> parse_reply("PP * Current Pan position is -500", "PP")
    Reply(ok=True, text='Current Pan position is -500', limit_events=(), echo='PP')
    >>> parse_reply("* 22", "PP").text, parse_reply("PP1000 *", "PP") is None
    ('22', True)
    >>> parse_reply("! Maximum allowable Pan position is 3090", "PP4000").ok
    False
    >>> parse_reply("R !T!T!P!P*", "R").limit_events
    ('T', 'T', 'P', 'P')
    >>> parse_reply("\x1b~#\ufffd* 1234", "PP") is None
    True
    """
    line = line.strip()
    if not line or len(line) > MAX_LINE or not (line.isascii() and line.isprintable()):
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
    A command carrying a value (a move, a setting) is answered by a bare ``*``, so a
    success with text is some query's answer, stale.

    >>> match_reply("*", "PP", numeric=True) is None, match_reply("* 5", "PP", numeric=True).text
    (True, '5')
    >>> match_reply("* 5", "PP100") is None, match_reply("*", "PP100").ok
    (True, True)
    """
    reply = parse_reply(line, sent)
    if reply is None or not reply.ok:
        return reply
    if numeric and reply_float(reply) is None:
        return None
    if reply.text and _WITH_VALUE.match(sent):
        return None
    return reply


def answers_probe(line: str) -> bool:
    """Whether ``line`` is the unit's answer to :data:`PROBE` (words, no number).

    >>> answers_probe("* Limit bounds are ENABLED (soft limits enabled)"), answers_probe("* 12")
    (True, False)
    """
    reply = parse_reply(line, PROBE)
    return bool(reply and reply.ok and reply.text and reply_float(reply) is None)


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

    A terse reply (no words) must be numbers alone: digits run into other signs are
    noise, not a value.

    >>> reply_float(parse_reply("* 185.1428 seconds arc per Pan position"))
    185.1428
    >>> reply_float(parse_reply("* 12#%34")) is None
    True
    """
    if not any(c.isalpha() for c in reply.text) and not _TERSE.match(reply.text):
        return None
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
