"""The wire contract: keys, envelope and messages, on good and on hostile input."""

from __future__ import annotations

import math

import msgpack
import pytest

from cyborg.protocol.access import ROLES, access_control, load_users
from cyborg.protocol.envelope import MAX_MESSAGE, decode, encode
from cyborg.protocol.errors import DecodeError, InvalidFieldError, ProtocolError, VersionError
from cyborg.protocol.keys import COMMANDS, Keys, check_client
from cyborg.protocol.messages import (
    MAX_TEXT,
    MESSAGES,
    REQUESTS,
    Ack,
    ChooseTarget,
    Event,
    Hello,
    InterestPoint,
    InterestResult,
    Message,
    PtuGoto,
    Status,
    SurveyStart,
    message_from,
)
from cyborg.protocol.version import PROTOCOL_MAJOR


def test_keys_are_all_under_the_rig() -> None:
    k = Keys("rig-7")
    telemetry = [*k.telemetry, k.alive]
    commands = [k.cmd("alice", name) for name in COMMANDS]
    assert all(key.startswith("cyborg/rig-7/") for key in telemetry + commands)
    assert len(set(telemetry + commands)) == len(telemetry) + len(commands)
    assert all(k.command_of(k.cmd("alice", name)) == ("alice", name) for name in COMMANDS)
    assert all(key.startswith(k.commands_of("alice")[:-2]) for key in commands)
    assert k.command_of("cyborg/other/cmd/alice/ptu/goto") is None
    for bad in ("", "a/b", "x*", "rig 1", "a" * 65):
        with pytest.raises(ValueError):
            Keys(bad)
    with pytest.raises(ValueError):
        k.cmd("alice", "ptu/explode")


@pytest.mark.parametrize(
    "name", ["", "a/b", "x*", "$*", "al ice", "a" * 65, "nul\x00", "rtl\u202e", "<b>", ".."]
)
def test_client_names_are_short_printable_identifiers(name: str) -> None:
    with pytest.raises(InvalidFieldError, match="client name"):
        check_client(name)
    with pytest.raises(ValueError):
        Keys("rig1").cmd(name, "hello")


def test_every_command_is_declared_once_on_its_request_class() -> None:
    """Verb, reply kind and whether it moves the head live on the class; the key space and
    the daemon's motion set derive from it."""
    assert set(COMMANDS) == set(REQUESTS)
    for verb, request in REQUESTS.items():
        assert verb == request.VERB and issubclass(request.REPLY, Message)
    moving = {verb for verb, request in REQUESTS.items() if request.MOVES}
    assert "ptu/goto" in moving and "ptu/halt" not in moving and "control/take" not in moving
    assert REQUESTS["survey/status"].REPLY is Status and REQUESTS["hello"].REPLY is Hello


def test_rig_text_is_clipped_so_clients_can_decode_it() -> None:
    long = "x" * (5 * MAX_TEXT)
    for msg in (Ack("ERROR", long), Event("info", long)):
        back = message_from(msg.KIND, decode(encode(msg.KIND, msg.to_body())).body)
        assert back == msg and len(encode(msg.KIND, msg.to_body())) < MAX_TEXT + 100


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
    with pytest.raises(VersionError, match=f"protocol {PROTOCOL_MAJOR} required"):
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


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('[[user]]\nname = "al ice"\nrole = "operator"', "client name"),
        ('[[user]]\nname = "alice"\nrole = "admin"', "role 'admin'"),
        ('[[user]]\nname = "alice"', "exactly a name and a role"),
        ('[[user]]\nname = "a"\nrole = "viewer"\n[[user]]\nname = "a"\nrole = "operator"', "twice"),
        ('[[user]]\nname = "rig1"\nrole = "viewer"', "twice"),
        ("admins = []", "unknown key"),
        ("[[user", "not valid TOML"),
    ],
)
def test_users_file_errors_say_what(text: str, message: str) -> None:
    with pytest.raises(ValueError, match=None) as info:
        load_users(text, "rig1")
    assert message in str(info.value)


def test_access_list_lets_each_name_query_only_its_own_commands() -> None:
    keys = Keys("rig1")
    users = load_users(
        '[[user]]\nname = "alice"\nrole = "operator"\n[[user]]\nname = "bob"\nrole = "viewer"',
        "rig1",
    )
    acl = access_control(keys, users, local=False)
    assert acl["enabled"] and acl["default_permission"] == "deny"
    rules = {r["id"]: r for r in acl["rules"]}
    assert rules["cmd-alice"]["key_exprs"] == ["cyborg/rig1/cmd/alice/**"]
    assert set(rules["cmd-bob"]["key_exprs"]) == {keys.cmd("bob", v) for v in ROLES["viewer"]}
    assert all(r["messages"] == ["query"] for k, r in rules.items() if k.startswith("cmd-"))
    # Only the rig may put: no rule but the rig's lets a put in.
    puts_in = [r for r in acl["rules"] if "put" in r["messages"] and "ingress" in r["flows"]]
    assert [r["id"] for r in puts_in] == ["rig"]
    assert {"rules": ["rig"], "subjects": ["rig", "rig-user"]} in acl["policies"]
    assert not any(s.get("link_protocols") for s in acl["subjects"])  # a router has no socket


def test_survey_settings_travel_as_name_value_texts_and_bad_forms_are_refused() -> None:
    """2.2: a survey start may carry the station's settings; the protocol checks their
    form (the rig, their meaning). Left out, they are None (the rig's configured ones)."""
    start = SurveyStart(profile="paper", settings=("uncommon=surprisal", "blur=8"))
    back = message_from(start.KIND, decode(encode(start.KIND, start.to_body())).body)
    assert back == start and back.settings == ("uncommon=surprisal", "blur=8")
    assert message_from("survey.start", {}).settings is None
    assert message_from("survey.start", {"settings": []}).settings == ()
    hostile = {
        "not a list": "blur=8",
        "not text": [8],
        "no value": ["blur="],
        "no name": ["=8"],
        "no equals": ["blur"],
        "odd name": ["bl ur=8"],
        "non-ascii name": ["blür=8"],
        "too long": ["blur=" + "8" * 300],
        "too many": ["blur=8"] * 33,
    }
    for value in hostile.values():
        with pytest.raises(InvalidFieldError, match="setting"):
            message_from("survey.start", {"settings": value})
