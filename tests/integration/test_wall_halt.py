"""HALT while the head goes to the chips and the worker still draws the analysis's products:
answered at once, the head stops, the drawing stops with its worker, the station is
incomplete with nothing half-written, its products are drawn again by the worker that
replaced the stopped one, and the next station completes (a real daemon, a real worker,
frozen so that its drawing cannot finish first)."""

from __future__ import annotations

import asyncio
import contextlib
import json
import os
import signal
from pathlib import Path

import pytest
from test_daemon import _state

from cyborg.clients.rigclient import RigClient, run_station, until_stage
from cyborg.protocol.messages import (
    InterestResult,
    PtuHalt,
    PtuState,
    SurveyProgress,
    SurveyStart,
    SurveyStatus,
    TakeControl,
)

pytestmark = pytest.mark.timeout(240)


async def test_halt_while_the_products_are_drawn_stops_the_head_and_the_drawing(
    daemon, client: RigClient
) -> None:
    await client.wait_alive()
    archive = Path(daemon.ready["archive"])
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    states = client.subscribe(client.keys.ptu_state, PtuState)
    await client.command(TakeControl())
    worker = (await client.call(SurveyStatus())).worker_pid
    # Full-size tiles: the products take long to draw, well past the points' arrival.
    station = (await client.command(SurveyStart(rows=2, cols=3, downsample=1.0))).detail
    chips = await until_stage(progress, station, {"chips", "done", "failed"})
    assert chips.stage == "chips"
    os.kill(worker, signal.SIGSTOP)  # the products stay undrawn until the HALT
    try:
        reply = await client.call(PtuHalt())
        assert reply.ok and "the survey was cancelled" in reply.detail
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(worker, signal.SIGCONT)
    final = await until_stage(progress, station, {"incomplete", "failed", "done"})
    assert final.stage == "incomplete"
    status = await client.call(SurveyStatus())
    assert status.worker_pid != worker  # the drawing's worker was stopped and replaced
    await _state(client, states)  # the head comes to a stop
    folder = archive / station
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["status"] == "incomplete" and manifest["points"]
    assert "products" not in manifest  # the stopped drawing published nothing half-written
    assert len(manifest["tiles"]) == 6 and "mosaic.png" in manifest["files"]
    async with asyncio.timeout(120):  # the replacement worker draws them again
        while "products" not in manifest:
            await asyncio.sleep(0.2)
            manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["status"] == "incomplete"  # ended as it ended; nothing the science found lost
    assert not (folder / ".analysis.partial").exists()
    assert manifest["products"]["overlay"] == "overlay.png"
    drawn = json.loads((folder / "analysis" / "result.json").read_text())
    assert len(drawn["points"]) == len(manifest["points"])  # the analysis the points came from
    for rel, size in manifest["files"].items():
        assert (folder / rel).stat().st_size == size, rel
    assert "analysis/overlay.png" in manifest["files"]
    result = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    assert len(result.points) == 3
    assert daemon.proc.returncode is None
