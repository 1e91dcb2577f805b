"""The scientist sets the next station's aim on the keypad (a real pty) and on the operator
console (headless Chromium), against a real daemon; the station seeks it and says so."""

from __future__ import annotations

import asyncio
import json
from pathlib import Path

import pytest
from test_keypad import Terminal, keypad  # noqa: F401  (the fixture)
from test_operator import browser, operator  # noqa: F401  (fixtures)

from bench.browser import MISSING, Browser

pytestmark = pytest.mark.timeout(240)


def _params_aim(daemon, station: str) -> str:
    """The aim the station's analysis ran with, as its result.json's params record it."""
    folder = Path(daemon.ready["archive"]) / station / "analysis"
    return json.loads((folder / "result.json").read_text())["params"]["aim"]


async def test_the_keypad_sets_the_next_station_s_aim(keypad: Terminal, daemon) -> None:  # noqa: F811
    await keypad.wait_for("● UP  control: nobody")
    await keypad.wait_for("aim  next station: any, the rig's")
    keypad.press(b"aa")  # any, dark
    keypad.press(b"x")  # no-vegetation set aside
    await keypad.wait_for("aim  next station: dark\\+no-vegetation, this keypad's")
    keypad.press(b"s")
    title = await keypad.wait_for(r"Interest points of (\S+) \(aim dark\+no-vegetation\):", 120)
    assert _params_aim(daemon, title[1]) == "dark+no-vegetation"
    await keypad.wait_for(r"survey \[#+\] done")
    keypad.press(b"aaa")  # bright, colour, then back to the rig's kind; still set aside
    await keypad.wait_for("aim  next station: no-vegetation, this keypad's")
    keypad.press(b"xxx")  # no-sky, both, nothing: the rig's, which kept the station's aim
    await keypad.wait_for("aim  next station: dark\\+no-vegetation, the rig's")
    keypad.press(b"q")
    assert await keypad.exit_status() == 0


@pytest.mark.skipif(bool(MISSING), reason=MISSING or "")
async def test_the_console_sends_the_chosen_aim_with_the_survey(
    daemon,
    operator: str,  # noqa: F811
    browser: Browser,  # noqa: F811
) -> None:
    js = browser.js
    wait = lambda expr, timeout=30.0: asyncio.to_thread(browser.wait, expr, timeout)  # noqa: E731
    await asyncio.to_thread(browser.open, operator)
    await wait("document.getElementById('alive').textContent.includes('up')")
    # Every kind and exclusion the protocol names is offered; left alone, the rig's is said.
    await wait("document.getElementById('aim').options.length === 5")
    offered = await asyncio.to_thread(
        js,
        "return [[...document.getElementById('aim').options].map(o => o.value),"
        " [...document.querySelectorAll('#aside input')].map(b => b.value)];",
    )
    assert offered == [["", "any", "dark", "bright", "colour"], ["no-vegetation", "no-sky"]]
    await wait("document.getElementById('aim').options[0].textContent === \"aim: rig's (any)\"")
    await asyncio.to_thread(
        js,
        "document.getElementById('aim').value = 'bright';"
        "document.querySelector('#aside input[value=\"no-sky\"]').checked = true;",
    )
    await asyncio.to_thread(browser.click, "#survey")
    heading = await wait(
        "document.getElementById('station').textContent.includes('(aim bright+no-sky)')"
        " && document.getElementById('station').textContent",
        120,
    )
    station = heading.removeprefix("Interest points of ").split(" ")[0]
    assert _params_aim(daemon, station) == "bright+no-sky"
    await wait(
        "document.getElementById('aim').options[0].textContent === \"aim: rig's (bright+no-sky)\""
    )
