"""Aims of study on the wire (2.5): a survey start carries one, checked and canonical; a
result and a status say which; a 2.4 peer, which knows no aim, still talks."""

from __future__ import annotations

import argparse
import re

import pytest

from cyborg.protocol.aims import add_aim_argument
from cyborg.protocol.envelope import decode, encode
from cyborg.protocol.errors import InvalidFieldError
from cyborg.protocol.messages import InterestResult, Message, Status, SurveyStart, message_from


def _over_the_wire(msg: Message) -> Message | None:
    return message_from(msg.KIND, decode(encode(msg.KIND, msg.to_body())).body)


def test_an_aim_travels_in_its_canonical_form() -> None:
    start = SurveyStart(rows=1, aim="No_Sky + dark")
    assert start.aim == "dark+no-sky"
    assert _over_the_wire(start) == start
    result = InterestResult("s/st01-300m", (), 540, 288, "dark+no-sky")
    assert _over_the_wire(result).aim == "dark+no-sky"
    status = Status("idle", aim="bright")
    assert _over_the_wire(status).aim == "bright"


def test_a_2_4_peer_still_talks() -> None:
    """Its survey start has no aim (the rig's choice applies); its result and status none
    (an empty aim: the science's own ranking)."""
    assert message_from("survey.start", {"rows": 2}).aim is None
    assert message_from("survey.result", {"station": "s/st01-300m"}).aim == ""
    assert message_from("status", {"state": "idle"}).aim == ""


@pytest.mark.parametrize(
    ("aim", "says"),
    [
        ("wet", "unknown 'wet' (kinds: any, dark, bright, colour; exclusions: no-vegetation"),
        ("dark+bright", "one kind at most (dark, bright)"),
        ("", "empty (kinds: any, dark, bright, colour)"),
    ],
)
def test_a_bad_aim_is_refused_naming_the_kinds(aim: str, says: str) -> None:
    with pytest.raises(InvalidFieldError, match=rf"survey\.start: aim .*{re.escape(says)}"):
        message_from("survey.start", {"aim": aim})
    with pytest.raises(ValueError, match=re.escape(says)):
        SurveyStart(aim=aim)


def test_the_command_line_reads_an_aim_and_refuses_a_bad_one_as_a_usage_error(
    capsys: pytest.CaptureFixture[str],
) -> None:
    parser = argparse.ArgumentParser(prog="t")
    add_aim_argument(parser, "default: the rig's")
    assert parser.parse_args([]).aim is None
    assert parser.parse_args(["--aim", "no-vegetation+colour"]).aim == "colour+no-vegetation"
    with pytest.raises(SystemExit) as exit_:
        parser.parse_args(["--aim", "lichen"])
    assert exit_.value.code == 2
    assert "unknown 'lichen' (kinds: any, dark, bright, colour" in capsys.readouterr().err
    assert "no-vegetation" in parser.format_help() and "colour:" in parser.format_help()
