"""The keypad's aim for the next station: ``a`` cycles the kind, ``x`` what is set aside;
left alone, the screen says which aim the rig will take; a result says what it sought."""

from __future__ import annotations

from cyborg.clients.keypad.view import Prompt, render
from cyborg.clients.watch import RigView
from cyborg.protocol.aims import KINDS
from cyborg.protocol.messages import InterestResult, Status


def _text(view: RigView, prompt: Prompt) -> str:
    return "\n".join(text for text, _ in render(view, prompt))


def test_a_cycles_every_kind_then_back_to_the_rig_s_choice() -> None:
    prompt = Prompt("rig1", "me", "")
    seen = [prompt.next_kind().aim for _ in range(len(KINDS) + 1)]
    assert seen == [*KINDS, None]


def test_x_sets_aside_each_exclusion_then_both_then_none() -> None:
    prompt = Prompt("rig1", "me", "")
    prompt.next_kind().next_kind()  # dark
    seen = [prompt.next_aside().aim for _ in range(4)]
    assert seen == ["dark+no-vegetation", "dark+no-sky", "dark+no-vegetation+no-sky", "dark"]
    prompt.kind = None  # the rig's kind, with something set aside: any kind, that set aside
    assert prompt.next_aside().aim == "no-vegetation"


def test_the_screen_says_which_aim_the_next_station_takes() -> None:
    view = RigView(alive=True, status=Status("idle", aim="bright"))
    prompt = Prompt("rig1", "me", "")
    assert " aim  next station: bright, the rig's (a: kind, x: set aside)" in _text(view, prompt)
    prompt.next_kind().next_kind().next_aside()
    assert " aim  next station: dark+no-vegetation, this keypad's" in _text(view, prompt)
    older = RigView(alive=True, status=Status("idle"))  # a rig before 2.5 names none
    assert " aim  next station: the rig's (a: kind" in _text(older, Prompt("rig1", "me", ""))


def test_a_result_says_what_its_station_sought() -> None:
    view = RigView(alive=True, result=InterestResult("s/st01-300m", (), 540, 288, "dark"))
    assert "Interest points of s/st01-300m (aim dark):" in _text(view, Prompt("r", "me", ""))
