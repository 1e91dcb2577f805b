"""``cyborg operator`` as a real process, its page in headless Chromium, a real daemon behind
a router: live frames, a survey started from the page, clicks that re-point the head."""

from __future__ import annotations

import asyncio
import math
from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from bench.browser import MISSING, Browser, chromium
from cyborg.clients.launch import operator as launch_operator
from cyborg.clients.rigclient import RigClient
from cyborg.protocol.messages import REQUESTS, Ack, PtuState, ReleaseControl, TakeControl

pytestmark = [pytest.mark.timeout(240), pytest.mark.skipif(bool(MISSING), reason=MISSING or "")]


@pytest.fixture
async def operator(router: str, tmp_path: Path) -> AsyncIterator[str]:
    """``cyborg operator`` on a free port; yields the page's URL."""
    async with launch_operator(router, "itest", "remote-op", tmp_path / "operator.log") as url:
        yield url
    assert b"Traceback" not in (tmp_path / "operator.log").read_bytes()


@pytest.fixture
def browser() -> AsyncIterator[Browser]:
    with chromium() as b:
        yield b


async def _still(states: asyncio.Queue[PtuState]) -> PtuState:
    async with asyncio.timeout(20):
        while True:
            s = await states.get()
            if not s.moving:
                return s


async def _drain(states: asyncio.Queue) -> None:
    while not states.empty():
        states.get_nowait()


async def test_operator_page_surveys_and_repoints(
    daemon, operator: str, browser: Browser, client: RigClient
) -> None:
    js = browser.js
    wait = lambda expr, timeout=30.0: asyncio.to_thread(browser.wait, expr, timeout)  # noqa: E731
    await asyncio.to_thread(browser.open, operator)
    # A live frame is drawn and acknowledged; the state arrives.
    await wait("window.cyborgStats().frames >= 3")
    assert await asyncio.to_thread(js, "return document.getElementById('live').width;") == 720
    await wait("document.getElementById('alive').textContent.includes('up')")
    # A thin link: the page asks for 320 px at 2 fps, and gets it; then the full view back.
    select = "const s = document.getElementById('view'); s.selectedIndex = arguments[0];"
    await asyncio.to_thread(js, select + "s.dispatchEvent(new Event('change'));", 2)
    await wait("document.getElementById('live').width === 320")
    await wait("document.getElementById('reply').textContent.includes('2fps-320w-q50')")
    await asyncio.to_thread(js, select + "s.dispatchEvent(new Event('change'));", 0)
    await wait("document.getElementById('live').width === 720")

    await client.wait_alive()
    states = client.subscribe(client.keys.ptu_state, PtuState, maxsize=1)

    # A survey started from the page completes and shows its overlay and points.
    await asyncio.to_thread(browser.click, "#survey")
    await wait("document.querySelectorAll('#points tbody tr').length === 3", 120)
    await wait("document.getElementById('mosaic').naturalWidth > 0")
    src = await asyncio.to_thread(js, "return document.getElementById('mosaic').src;")
    assert src.endswith("/analysis/overlay.png")
    assert "control: you" in await asyncio.to_thread(
        js, "return document.getElementById('control').textContent;"
    )
    await wait("document.querySelectorAll('#chips img').length === 3")
    await wait("[...document.querySelectorAll('#chips img')].every(i => i.naturalWidth > 0)")
    result = await asyncio.to_thread(js, "return window.cyborgState();")
    best = result["points"][0]

    # A click on the mosaic at the best point re-points the head there.
    box = await asyncio.to_thread(
        js,
        "const r = document.getElementById('mosaic').getBoundingClientRect();"
        "return [r.width, r.height];",
    )
    dx = ((best["x"] + 0.5) / result["width"] - 0.5) * box[0]
    dy = ((best["y"] + 0.5) / result["height"] - 0.5) * box[1]
    await _drain(states)
    await asyncio.to_thread(browser.click, "#mosaic", dx, dy)
    reply = await wait(
        "document.getElementById('reply').textContent.startsWith('ptu/look') && "
        "document.getElementById('reply').textContent"
    )
    assert reply.startswith("ptu/look: looking at"), reply
    await asyncio.sleep(0.3)
    here = await _still(states)
    deg_per_css_px = 90.0 / box[0]  # 3 tiles of 30 deg across the image
    assert abs(here.pan - best["pan"]) < deg_per_css_px + 0.06
    assert abs(here.tilt - best["tilt"]) < deg_per_css_px + 0.06

    # A click a quarter of the width right of the live view's centre turns the head by
    # atan(0.5 tan 15 deg / cos tilt) (a pinhole with a 30 deg field of view, tilted): 7.63
    # deg level.
    await asyncio.sleep(0.5)  # a frame taken at the new pose is on the canvas
    shown = await asyncio.to_thread(js, "return window.cyborgStats().last;")
    width = await asyncio.to_thread(
        js, "return document.getElementById('live').getBoundingClientRect().width;"
    )
    await _drain(states)
    await asyncio.to_thread(browser.click, "#live", width / 4, 0)
    await asyncio.sleep(0.3)
    here = await _still(states)
    turn = math.degrees(
        math.atan(0.5 * math.tan(math.radians(15)) / math.cos(math.radians(shown["tilt"])))
    )
    assert here.pan - shown["pan"] == pytest.approx(turn, abs=0.15)

    # Halt from the page; the archive lists the session.
    await asyncio.to_thread(browser.click, "#halt")
    await wait("document.getElementById('reply').textContent.startsWith('ptu/halt: halted')")
    session = result["station"].split("/")[0]
    await asyncio.to_thread(browser.click, "#refresh")
    await wait(f"document.getElementById('sessions').textContent.includes('{session}')")
    # The session's report is listed first, and opens through the console whole.
    await asyncio.to_thread(
        js, "Array.from(document.querySelectorAll('#sessions a')).at(-1).click();"
    )
    await wait("document.querySelector('#products a')?.textContent === 'report.html'")
    base = operator.split("?", 1)[0].rstrip("/")
    await asyncio.to_thread(browser.open, f"{base}/archive/{session}/report.html")
    await wait("document.images.length > 5")
    broken = await asyncio.to_thread(
        js,
        "return Array.from(document.images).filter((i) => !(i.complete && i.naturalWidth)).length;",
    )
    assert broken == 0


async def test_operator_refuses_plainly(
    daemon, operator: str, browser: Browser, other_client
) -> None:
    await asyncio.to_thread(browser.open, operator)
    await asyncio.to_thread(browser.wait, "window.cyborgStats().frames >= 1")
    await other_client.wait_alive()
    await other_client.command(TakeControl())
    post = (
        "return fetch('/api/ptu/goto', {method: 'POST', body: arguments[0], headers: "
        "{'content-type': 'application/json'}}).then(r => r.json());"
    )
    reply = await asyncio.to_thread(browser.js, post, '{"pan": 1, "tilt": 1}')
    assert reply["ok"] is False and reply["result"] == "REJECTED" and "intruder" in reply["detail"]
    # The page's commands come from the protocol's registry, and say which need control.
    commands = await asyncio.to_thread(
        browser.js, "return fetch('/api/commands').then(r => r.json());"
    )
    assert commands == {
        verb: {"moves": kind.MOVES, "read_only": kind.READ_ONLY}
        for verb, kind in REQUESTS.items()
        if kind.REPLY is Ack
    }
    await asyncio.to_thread(
        browser.wait, "document.getElementById('home').title.includes('needs control')"
    )
    title = "return document.getElementById('take').title;"
    assert "needs control" not in await asyncio.to_thread(browser.js, title)
    bad = await asyncio.to_thread(browser.js, post, "{not json")
    assert bad["ok"] is False and bad["result"] == "ERROR"
    # A station's settings typed on the page reach the rig, which names what it refuses.
    await other_client.call(ReleaseControl())
    await asyncio.to_thread(browser.click, "#take")
    await asyncio.to_thread(
        browser.wait, "document.getElementById('reply').textContent.startsWith('control/take')"
    )
    type_in = "const s = document.getElementById('settings'); s.value = arguments[0];"
    await asyncio.to_thread(browser.js, type_in, " top_n=2   blurr=8 ")
    await asyncio.to_thread(browser.click, "#survey")
    reply = await asyncio.to_thread(
        browser.wait,
        "document.getElementById('reply').textContent.startsWith('survey/start') && "
        "document.getElementById('reply').textContent",
        30.0,
    )
    assert reply == (
        "survey/start: REJECTED: survey/start: settings: unknown parameter 'blurr' "
        "(did you mean blur?)"
    ), reply
