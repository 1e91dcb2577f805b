"""A real daemon on a noisy serial line: noise bursts glued onto the replies of moves it
sends mid-survey, and a position reply rewritten to one the head cannot be at. The
station completes, the driver says it retried, and no impossible pose is published or
archived."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from cyborg.clients.rigclient import RigClient, run_station
from cyborg.protocol.messages import (
    InterestResult,
    PtuState,
    SurveyProgress,
    SurveyStart,
    TakeControl,
)

pytestmark = pytest.mark.timeout(180)

PAN_LIMIT, TILT_MIN, TILT_MAX = 158.91, -46.64, 31.12
"""The D46-17's limits in degrees, as the emulated unit reports them."""


async def test_a_survey_completes_through_noise_and_impossible_positions(
    start_daemon, client: RigClient, tmp_path: Path
) -> None:
    # "PP-" and "TP0" are moves only the survey sends (state polls are bare "PP"/"TP");
    # the first PP is the connect's, the second TP the first state poll's.
    faults = ("noise:PP-:1", "noise:TP0:2", "rewrite:PP:1", "rewrite:TP:2")
    daemon = await start_daemon("".join(f"&fault={f}" for f in faults))
    await client.wait_alive()
    states = client.subscribe(client.keys.ptu_state, PtuState)
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    await client.command(TakeControl())
    result = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    assert len(result.points) == 3
    assert await daemon.stop() == 0
    log = daemon.log.read_text()
    assert log.count("injected fault: noise") == 2  # they did strike
    assert log.count("line resynchronised, sending it again") >= 2
    assert log.count("injected fault: rewrite") == 2
    assert "PTU answered PP with 99999" in log and "PTU answered TP with 99999" in log
    manifest = json.loads((tmp_path / "archive" / result.station / "manifest.json").read_text())
    assert manifest["status"] == "complete"
    poses = [(e["pan"], e["tilt"]) for e in manifest["tiles"] + manifest["chips"]]
    published = []
    while not states.empty():
        state = states.get_nowait()
        published.append((state.pan, state.tilt))
    assert published and len(poses) == 5
    for pan, tilt in poses + published:
        assert -PAN_LIMIT <= pan <= PAN_LIMIT and TILT_MIN <= tilt <= TILT_MAX
