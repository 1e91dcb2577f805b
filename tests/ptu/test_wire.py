"""The line codec on the awkward cases real units and real lines produce."""

from __future__ import annotations

import pytest

from cyborg.daemon.ptu.wire import (
    LineFramer,
    format_command,
    parse_reply,
    reply_float,
    reply_int,
    split_limit_events,
)


def test_format_command() -> None:
    assert format_command("tp", 0) == b"TP0 "
    assert format_command("PS", 2902) == b"PS2902 "
    for bad in ("", "PP 1", "P1", "PPPPP"):
        with pytest.raises(ValueError):
            format_command(bad)
    with pytest.raises(ValueError):
        format_command("PP", 1.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        format_command("PP", True)


@pytest.mark.parametrize(
    ("line", "sent", "value"),
    [
        ("* 1000", "PS", 1000),
        ("* Target Pan speed is 1000 positions/sec", "PS", 1000),
        ("PS * Target Pan speed is 1000 positions/sec", "PS", 1000),
        ("* Pan speed is 600 pos/sec", "PS", 600),
        ("* Tilt acceleration is 2000 positions/sec^2", "TA", 2000),
        ("* Current Tilt position is -907", "TP", -907),
        ("pp * -12", "PP", -12),
        ("* 3091", "PX", 3091),
    ],
)
def test_numbers_come_from_patterns_not_sentences(line: str, sent: str, value: int) -> None:
    reply = parse_reply(line, sent)
    assert reply is not None and reply.ok
    assert reply_int(reply) == value


@pytest.mark.parametrize(
    "line", ["* 185.1428 seconds arc per Pan position", "* 92.5714 seconds arc per position"]
)
def test_resolution_with_and_without_axis_name(line: str) -> None:
    reply = parse_reply(line, "PR")
    assert reply is not None
    assert reply_float(reply) in (185.1428, 92.5714)


def test_stale_echo_never_answers_another_command() -> None:
    assert parse_reply("PP1000 *", "PP") is None
    assert parse_reply("TP * 5", "PP") is None
    assert parse_reply("PP1000 *", "PP1000") is not None


@pytest.mark.parametrize(
    "line",
    [
        "Pan-Tilt Controller v2.12.1d1, (C)2003 Directed Perception, Inc.",
        "Initializing...",
        "\x00\ufffd#%garbage~",
        "independent (default) speed control mode",
        "",
        "*" * 600,
    ],
)
def test_banners_and_garbage_are_not_replies(line: str) -> None:
    assert parse_reply(line, "PP") is None


def test_errors_and_limit_events() -> None:
    reply = parse_reply("! Maximum allowable Pan position is 3090", "PP4000")
    assert reply is not None and not reply.ok
    assert reply.text == "Maximum allowable Pan position is 3090"
    reply = parse_reply("!P* 12", "PP")
    assert reply is not None and reply.ok and reply.limit_events == ("P",)
    assert reply_int(reply) == 12
    assert parse_reply("!T", "PP") is None
    assert split_limit_events("!T!P") == ("", ("T", "P"))
    # "! Pan speed..." is an error message, not a limit event.
    assert split_limit_events("! Pan speed cannot exceed 2902 positions/sec")[1] == ()


def test_query_reply_without_number() -> None:
    reply = parse_reply("*", "PP")
    assert reply is not None and reply_int(reply) is None


def test_framer_byte_by_byte_and_overlong_garbage() -> None:
    framer = LineFramer()
    stream = b"\r\nPP * 5\r\n\x00\r\n* 7\r\n"
    lines = [line for b in stream for line in framer.feed(bytes((b,)))]
    assert lines == ["PP * 5", "* 7"]
    assert framer.feed(b"x" * 2000) == []
    assert framer.pending() == ""
    assert framer.feed(b"* 1\r\n") == ["* 1"]
    framer.feed(b"PP ")
    assert framer.pending() == "PP "
