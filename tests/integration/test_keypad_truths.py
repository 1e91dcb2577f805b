"""``cyborg keypad`` in a real pseudo-terminal (pyte) says only what is so: arrows it can
show under a C locale, points that await a choice, points that are no further target,
and a HALT sent by another client."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import pytest
from test_keypad import Terminal, keypad  # noqa: F401  (the fixture)
from test_replay import at_end, start_replay, write_recording  # noqa: F401  (a fixture)

from cyborg.clients.rigclient import RigClient
from cyborg.protocol.messages import PtuHalt

pytestmark = pytest.mark.timeout(180)


def _keypad(router: str, rig: str, locale: str = "C.UTF-8") -> Terminal:
    argv = [sys.executable, "-m", "cyborg.clients", "keypad", "--rig", rig]
    return Terminal([*argv, "--connect", router, "--name", "arm"], locale=locale)


async def test_a_c_locale_gets_ascii_arrows(router: str) -> None:
    term = _keypad(router, "itest", locale="C")
    try:
        await term.wait_for(r"o not seen yet")
        await term.wait_for(r"\n <\^v> jog  \+/- step")
        term.press(b"q")
        assert await term.exit_status() == 0
    finally:
        term.close()


async def test_points_await_a_choice_and_no_further_target_cannot_be_chosen(
    router: str,
    start_replay: Callable,  # noqa: F811
    tmp_path: Path,
) -> None:
    """Opened after the station ended (the replay answers on): its progress is gone, its
    points wait; #2 is no further target."""
    async with start_replay(write_recording(tmp_path, gap_s=0.2)) as replay:
        await at_end(replay)
        term = _keypad(router, "demo")
        try:
            await term.wait_for("● UP")
            await term.wait_for(r"survey  points of \S+/st01-300m await a choice: 1/0")
            assert "none yet" not in term.text
            await term.wait_for(r"#2  score\s+0.04 .* no further target")
            term.press(b"2")
            await term.wait_for(r"choose: #2 is no further target")
            term.press(b"1")  # a target: sent, and the replay refuses it
            await term.wait_for(r"choose #1: replay: read-only, motion refused")
            term.press(b"q")
            assert await term.exit_status() == 0
        finally:
            term.close()
        assert b"Traceback" not in term.raw


async def test_a_halt_from_another_client_is_announced(
    keypad: Terminal,  # noqa: F811
    daemon,
    other_client: RigClient,
) -> None:
    await keypad.wait_for("● UP")
    await other_client.wait_alive()
    await other_client.command(PtuHalt())
    await keypad.wait_for("HALT from intruder")
    keypad.press(b"q")
    assert await keypad.exit_status() == 0
