"""The wire contract: keys, envelope and messages, on good and on hostile input."""

from __future__ import annotations

import math

import msgpack
import pytest

from protocol.envelope import MAX_MESSAGE, decode, encode
from protocol.errors import DecodeError, InvalidFieldError, ProtocolError, VersionError
from protocol.keys import COMMANDS, Keys
from protocol.messages import (
    MESSAGES,
    Ack,
    ChooseTarget,
    InterestPoint,
    InterestResult,
    PtuGoto,
    SurveyStart,
    message_from,
)
from protocol.version import PROTOCOL_MAJOR


def test_keys_are_all_under_the_rig() -> None:
    k = Keys("rig-7")
    telemetry = [k.frame, k.ptu_state, k.progress, k.result, k.chip, k.events, k.alive]
    commands = [k.cmd(name) for name in COMMANDS]
    assert all(key.startswith("cyborg/rig-7/") for key in telemetry + commands)
    assert len(set(telemetry + commands)) == len(telemetry) + len(commands)
    assert all(k.command_of(k.cmd(name)) == name for name in COMMANDS)
    assert k.command_of("cyborg/rig-7/cmd/ptu/explode") is None
    assert k.command_of("cyborg/other/cmd/ptu/goto") is None
    for bad in ("", "a/b", "x*", "rig 1", "a" * 65):
        with pytest.raises(ValueError):
            Keys(bad)
    with pytest.raises(ValueError):
        k.cmd("ptu/explode")


def test_round_trip_every_kind() -> None:
    samples = {
        "survey.result": InterestResult(
            "s1/st2", (InterestPoint(1, 10.5, 20.0, 0.9, -3.0, 2.5, "H class 5 of 6"),), 720, 576
        ),
        "ptu.goto": PtuGoto(12.5, -4.0),
        "ack": Ack("LIMIT", "pan 170 deg is outside the soft limits"),
    }
    for kind, msg in samples.items():
        env = decode(encode(kind, msg.to_body(), seq=9, src="test", corr="c1"))
        assert (env.kind, env.seq, env.src, env.corr) == (kind, 9, "test", "c1")
        assert message_from(env.kind, env.body) == msg
    for cls in MESSAGES.values():
        assert cls.KIND and MESSAGES[cls.KIND] is cls


def test_unknown_fields_and_kinds_are_ignored_missing_optional_take_defaults() -> None:
    start = message_from("survey.start", {"rows": 3, "future_field": [1, 2]})
    assert start == SurveyStart(rows=3)
    assert message_from("survey.teleport", {"x": 1}) is None
    env = decode(msgpack.packb({"v": PROTOCOL_MAJOR, "k": "ptu.halt", "new": 1}))
    assert env.body == {} and env.minor == 0


@pytest.mark.parametrize(
    "data",
    [
        b"",
        b"\xc1",
        b"\x93\x01\x02\x03",
        msgpack.packb("hello"),
        msgpack.packb({"k": "ptu.goto", "body": {}}),
        msgpack.packb({"v": "1", "k": "ptu.goto"}),
        msgpack.packb({"v": True, "k": "ptu.goto"}),
        msgpack.packb({"v": PROTOCOL_MAJOR}),
        msgpack.packb({"v": PROTOCOL_MAJOR, "k": "ptu.goto", "body": [1, 2]}),
        msgpack.packb({"v": PROTOCOL_MAJOR, "k": "ptu.goto", "seq": "x"}),
        msgpack.packb({"v": PROTOCOL_MAJOR, "k": "ptu.goto", "corr": 5}),
        msgpack.packb({1: 2}),
        msgpack.packb({"v": PROTOCOL_MAJOR, "k": "x", "body": {"a": msgpack.ExtType(5, b"z")}}),
        b"\x91" * 100_000 + b"\x00",
        msgpack.packb({"v": PROTOCOL_MAJOR, "k": "x", "body": {"a": list(range(20_000))}}),
        msgpack.packb({"v": PROTOCOL_MAJOR, "k": "x", "body": {"a": "é" * 70_000}}),
    ],
)
def test_malformed_input_is_a_protocol_error(data: bytes) -> None:
    with pytest.raises(DecodeError):
        decode(data)


def test_oversized_and_wrong_version() -> None:
    with pytest.raises(DecodeError, match="exceeds"):
        decode(b"\x00" * (MAX_MESSAGE + 1))
    with pytest.raises(DecodeError, match="exceeds"):
        decode(encode("x", {"blob": b"\x00" * 2000}), max_size=1000)
    wrong = msgpack.packb({"v": PROTOCOL_MAJOR + 1, "k": "ptu.goto", "body": {}})
    with pytest.raises(VersionError, match=f"major {PROTOCOL_MAJOR + 1} is not supported"):
        decode(wrong)
    # A newer minor is fine.
    assert decode(msgpack.packb({"v": PROTOCOL_MAJOR, "mv": 99, "k": "ptu.halt"})).minor == 99


@pytest.mark.parametrize(
    ("kind", "body"),
    [
        ("ptu.goto", {"pan": "10", "tilt": 0}),
        ("ptu.goto", {"pan": math.nan, "tilt": 0}),
        ("ptu.goto", {"pan": math.inf, "tilt": 0}),
        ("ptu.goto", {"pan": True, "tilt": 0}),
        ("ptu.goto", {"pan": 1e9, "tilt": 0}),
        ("ptu.jog", {"pan": 500.0}),
        ("survey.start", {"rows": 0}),
        ("survey.start", {"rows": 2.5}),
        ("survey.start", {"downsample": 0.0}),
        ("target.choose", {"station": "s", "rank": 4}),
        ("control.take", {"client": "x" * 5000}),
        ("ack", {"result": "MAYBE"}),
        ("survey.result", {"station": "s", "points": [{"rank": 1}]}),
        ("survey.result", {"station": "s", "points": "nope"}),
    ],
)
def test_invalid_fields(kind: str, body: dict) -> None:
    with pytest.raises(ProtocolError):
        message_from(kind, body)


def test_errors_are_value_errors_with_sendable_text() -> None:
    with pytest.raises(ValueError) as info:
        message_from("target.choose", {"station": "s1", "rank": -1})
    assert isinstance(info.value, InvalidFieldError)
    assert "rank -1 outside 0..3" in str(info.value)
    assert ChooseTarget("s", 0).rank == 0
    with pytest.raises(DecodeError, match="missing field 'station'"):
        message_from("target.choose", {"rank": 1})
