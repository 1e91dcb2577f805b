"""The session report, written by a real daemon after each station and each choice, fetched
with ``cyborg report`` and rendered in headless Chromium: every image loads, every point's
reason and the choice are there, and it prints."""

from __future__ import annotations

import asyncio
import sys
from pathlib import Path

import pytest

from bench.browser import MISSING, chromium
from cyborg.clients.rigclient import RigClient, run_station
from cyborg.protocol.messages import (
    ChooseTarget,
    InterestResult,
    SurveyProgress,
    SurveyStart,
    TakeControl,
)

pytestmark = [pytest.mark.timeout(240), pytest.mark.skipif(bool(MISSING), reason=MISSING or "")]


async def test_the_report_reads_and_prints(
    start_daemon, client: RigClient, router: str, tmp_path: Path
) -> None:
    daemon = await start_daemon()
    await client.wait_alive()
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    await client.command(TakeControl())
    first = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    await client.command(ChooseTarget(first.station, 1))
    second = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    session = first.station.split("/")[0]
    page = Path(daemon.ready["archive"]) / session / "report.html"
    assert page.is_file()
    proc = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "cyborg.clients", "report", session, "--out", str(tmp_path),
        "--rig", "itest", "--connect", router, "--name", "reader",
        stdout=asyncio.subprocess.PIPE,
    )  # fmt: skip
    await proc.communicate()
    assert proc.returncode == 0
    fetched = tmp_path / f"report-{session}.html"
    assert fetched.read_bytes() == page.read_bytes()

    def look() -> tuple[list, str, bytes, bytes]:
        with chromium() as browser:
            browser.open(page.as_uri())
            broken = browser.js(
                "return Array.from(document.images)"
                ".filter((i) => !(i.complete && i.naturalWidth > 0)).map((i) => i.alt);"
            )
            text = browser.js("return document.body.innerText;")
            shot = browser.screenshot()
            pdf = browser.print_pdf()
        return broken, text, shot, pdf

    broken, text, shot, pdf = await asyncio.to_thread(look)
    assert broken == []
    for point in (*first.points, *second.points):
        assert point.why in text
    assert "chose #1 by tester" in text and "240 m towards pan" in text
    assert shot.startswith(b"\x89PNG") and pdf.startswith(b"%PDF")
