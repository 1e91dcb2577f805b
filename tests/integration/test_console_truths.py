"""``cyborg operator``'s page in headless Chromium says only what is so, against a rig
played back by ``cyborg replay`` (a real process on a real router): points that await a
choice, points that are no further target, a 24-hour log, no stale points after a restart."""

from __future__ import annotations

import asyncio
import signal
from collections.abc import Callable
from pathlib import Path

import pytest
from test_operator import browser, operator  # noqa: F401  (fixtures)
from test_replay import at_end, start_replay, write_recording  # noqa: F401  (a fixture)

from bench.browser import MISSING, Browser
from cyborg.clients.launch import operator as launch_operator

pytestmark = [pytest.mark.timeout(180), pytest.mark.skipif(bool(MISSING), reason=MISSING or "")]

ROWS = "document.querySelectorAll('#points tbody tr')"


async def _open(browser: Browser, url: str) -> Callable:  # noqa: F811
    """The page, open and up; returns a waiter for a JS expression."""
    await asyncio.to_thread(browser.open, url)
    wait = lambda expr, timeout=30.0: asyncio.to_thread(browser.wait, expr, timeout)  # noqa: E731
    await wait("document.getElementById('alive').textContent.includes('up')")
    return wait


async def test_points_await_a_choice_and_no_further_target_has_no_choose(
    router: str,
    start_replay: Callable,  # noqa: F811
    browser: Browser,  # noqa: F811
    tmp_path: Path,
) -> None:
    """The console starts after the station ended: it saw no progress, and points wait."""
    log = tmp_path / "operator.log"
    async with start_replay(write_recording(tmp_path, 0.2), "--as-rig", "itest") as replay:
        await at_end(replay)
        async with launch_operator(router, "itest", "remote-op", log) as url:
            wait = await _open(browser, url)
            await wait(f"{ROWS}.length === 2")
            text = await wait("document.getElementById('progresstext').textContent")
            assert text == "points of 20260101-120000/st01-300m await a choice", text
            rows = await asyncio.to_thread(
                browser.js,
                f"return [...{ROWS}].map(r => [r.className, r.lastChild.textContent]);",
            )
            assert rows == [["", "Choose 1Look"], ["notarget", "no further target Look"]]
            await asyncio.to_thread(browser.open, "about:blank")  # its socket closed first
    assert b"Traceback" not in log.read_bytes()


async def test_the_log_reads_24_hour_time(
    start_replay: Callable,  # noqa: F811
    operator: str,  # noqa: F811
    browser: Browser,  # noqa: F811
    tmp_path: Path,
) -> None:
    async with start_replay(write_recording(tmp_path, 0.2), "--as-rig", "itest") as replay:
        await at_end(replay)
        wait = await _open(browser, operator)
        await asyncio.to_thread(browser.click, "#halt")  # refused: a line in the log
        line = await wait(
            "[...document.querySelectorAll('#log li')].map(li => li.textContent)"
            ".find(t => t.includes('ptu/halt'))"
        )
        assert line[2] == ":" and line[5] == ":" and line[8] == " ", line
        assert "M " not in line[:12], line  # no AM/PM


async def test_a_restarted_rig_leaves_no_stale_points(
    start_replay: Callable,  # noqa: F811
    operator: str,  # noqa: F811
    browser: Browser,  # noqa: F811
    tmp_path: Path,
) -> None:
    async with start_replay(write_recording(tmp_path, 0.2), "--as-rig", "itest") as first:
        await at_end(first)
        wait = await _open(browser, operator)
        await wait(f"{ROWS}.length === 2")
        first.send_signal(signal.SIGINT)
        await first.wait()
        await wait("document.getElementById('alive').textContent.includes('DOWN')")
    # The rig comes back mid-station of a new session: nothing awaits a choice.
    later = write_recording(tmp_path, 3600, session="20260101-130000")
    async with start_replay(later, "--as-rig", "itest"):
        await wait("document.getElementById('state').textContent.startsWith('surveying')")
        await wait(f"{ROWS}.length === 0")
        assert not await asyncio.to_thread(
            browser.js, "return document.querySelectorAll('#points button').length;"
        )
