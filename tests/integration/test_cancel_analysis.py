"""A scientist who changes their mind during the analysis: the cancelled station leaves no
partial analysis behind, and the next station completes (a real daemon, a real worker)."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from cyborg.clients.rigclient import RigClient, run_station, until_stage
from cyborg.protocol.messages import (
    Event,
    InterestResult,
    PtuHalt,
    SurveyCancel,
    SurveyProgress,
    SurveyStart,
    SurveyStatus,
    TakeControl,
)

pytestmark = pytest.mark.timeout(240)


@pytest.mark.parametrize("stop", [SurveyCancel(), PtuHalt()], ids=["cancel", "halt"])
async def test_cancel_in_analysis_then_the_next_station_completes(
    daemon, client: RigClient, stop
) -> None:
    await client.wait_alive()
    archive = Path(daemon.ready["archive"])
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    events = client.subscribe(client.keys.events, Event)
    await client.command(TakeControl())
    for frozen in (True, False):
        worker = (await client.call(SurveyStatus())).worker_pid
        if frozen:  # the analysis cannot finish before the cancel, however fast it is
            os.kill(worker, signal.SIGSTOP)
        request = SurveyStart(rows=2, cols=3, downsample=1.0)
        station = (await client.command(request)).detail
        await until_stage(progress, station, {"analysis"})
        await client.command(stop)
        final = await until_stage(progress, station, {"incomplete", "failed", "done"})
        assert final.stage == "incomplete"
        assert not (archive / station / ".analysis.partial").exists()
        result = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
        assert len(result.points) == 3
        status = await client.call(SurveyStatus())
        assert status.state == "awaiting-choice" and not status.last_error
        assert status.worker_pid != worker  # the cancelled job's worker was replaced
    texts = []
    while not events.empty():
        texts.append(events.get_nowait().text)
    assert not any("died" in t for t in texts), texts  # a cancel is not a crash
    assert daemon.proc.returncode is None
