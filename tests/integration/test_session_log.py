"""The session log (``session.mcap``) written by a real daemon, read back with the official
``mcap`` reader, every message checked against its channel's schema (Foxglove's, vendored in
``protocol/foxglove``; the protocol's own, derived from its classes), and replayed onto the
bus for the keypad's view."""

from __future__ import annotations

import asyncio
import base64
import json
import signal
from collections import Counter
from pathlib import Path

import pytest

from cyborg.clients.replay import read_log, replay
from cyborg.clients.rigclient import RigClient, run_station
from cyborg.clients.watch import RigWatch
from cyborg.protocol import recording as rec
from cyborg.protocol.messages import (
    Chip,
    ChooseTarget,
    InterestResult,
    PtuHalt,
    SurveyCancel,
    SurveyProgress,
    SurveyStart,
    TakeControl,
)
from cyborg.protocol.transport import Transport
from cyborg.protocol.version import PROTOCOL_MAJOR, PROTOCOL_MINOR
from tests.integration.logcheck import Checked

pytestmark = pytest.mark.timeout(180)


async def _surveyed(start_daemon, client: RigClient) -> tuple[Path, InterestResult, list[Chip]]:
    """One station through a real daemon, then SIGTERM; returns the session folder, the
    result and the chips as the bus delivered them."""
    daemon = await start_daemon()
    await client.wait_alive()
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    chips = client.subscribe(client.keys.chip, Chip)
    await client.command(TakeControl())
    result = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    await asyncio.sleep(0.5)
    assert await daemon.stop() == 0
    got = [chips.get_nowait() for _ in range(chips.qsize())]
    session = Path(daemon.ready["archive"]) / result.station.split("/")[0]
    return session, result, got


async def test_the_session_log_holds_the_station(start_daemon, client: RigClient) -> None:
    session, result, chips = await _surveyed(start_daemon, client)
    metadata, messages = read_log(session / "session.mcap")
    assert (
        metadata["session"]["rig"] == "itest"
        and metadata["session"]["protocol"] == f"{PROTOCOL_MAJOR}.{PROTOCOL_MINOR}"
    )
    counts = Counter(m.topic for m in messages)
    assert counts[rec.TOPICS["survey.result"]] == 1
    assert counts[rec.MOSAIC] == counts[rec.ANNOTATIONS] == 1
    assert counts[rec.TOPICS["survey.chip"]] == counts["/survey/chip/image"] == 3
    assert counts[rec.TOPICS["ptu.state"]] == counts[rec.TF] > 0
    assert counts[rec.TOPICS["survey.progress"]] >= 3 and counts[rec.LOG] >= 1
    assert counts[rec.TOPICS["cam.frame"]] == counts["/camera/live"] > 0  # 1 fps, unwatched
    times = [m.log_time for m in messages]
    assert times == sorted(times)
    # The official reader opens it; every message fits its schema, each schema stored once.
    checked = Checked(session / "session.mcap")
    assert len(checked.messages) == len(messages)
    assert len(set(checked.schemas)) == len(checked.schemas)
    # Images are byte-identical: the mosaic with the archive's, the chips with the bus's.
    (mosaic,) = [m for m in messages if m.topic == rec.MOSAIC]
    png = base64.b64decode(json.loads(mosaic.data)["data"])
    assert png == (session.parent / result.station / "mosaic.png").read_bytes()
    images = [
        base64.b64decode(json.loads(m.data)["data"])
        for m in messages
        if m.topic == "/survey/chip/image"
    ]
    assert sorted(images) == sorted(c.jpeg for c in chips)
    # The rings are on the mosaic's timestamp, at the points.
    (notes,) = [json.loads(m.data) for m in messages if m.topic == rec.ANNOTATIONS]
    stamp = json.loads(mosaic.data)["timestamp"]
    assert all(c["timestamp"] == stamp for c in notes["circles"])
    targets = [p for p in result.points if p.target]
    centres = [(c["position"]["x"], c["position"]["y"]) for c in notes["circles"]]
    assert centres == [(p.x + 0.5, p.y + 0.5) for p in targets]
    # Short labels; the whole reason is the annotation's metadata.
    for text, p in zip(notes["texts"], targets, strict=True):
        assert text["text"] == rec.label(p) and len(text["text"]) <= rec.LABEL_CHARS + 4
        assert {"key": "why", "value": p.why} in text["metadata"]


SITE = {"name": "Rivas Vaciamadrid", "latitude": 40.331, "longitude": -3.517, "altitude": 612.5}


async def test_a_walk_logs_where_each_station_stood_and_every_decision(
    start_daemon, client: RigClient
) -> None:
    """With [site] set: two stations walked and chosen (300, 60 m), a third halted, a
    fourth cancelled. The log has a LocationFix per station, where its manifest places
    it, the site in its metadata, and each choice, the HALT and both incomplete stations
    in /log, with who."""
    daemon = await start_daemon(sections={"site": SITE | {"heading": 350.0}})
    await client.wait_alive()
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    await client.command(TakeControl())
    stations = []
    for _ in range(2):
        result = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
        await client.command(ChooseTarget(result.station, 1))
        stations.append(result.station)
    for stop in (PtuHalt(), SurveyCancel()):
        station = (await client.command(SurveyStart(rows=2, cols=3))).detail
        stations.append(station)
        async with asyncio.timeout(60):
            while (p := await progress.get()).station != station or p.stage != "tiles":
                pass
        await client.command(stop)  # mid-mosaic: six tiles, analysis and chips to go
        while (p := await progress.get()).station != station or p.stage != "incomplete":
            pass
    assert await daemon.stop() == 0
    archive = Path(daemon.ready["archive"])
    sites = [json.loads((archive / s / "manifest.json").read_text())["site"] for s in stations]
    log = Checked(archive / stations[0].split("/")[0] / "session.mcap")

    fixes = log.on(rec.LOCATION)
    assert [f["metadata"][0] for f in fixes] == [{"key": "station", "value": s} for s in stations]
    for fix, site in zip(fixes, sites, strict=True):
        assert (fix["latitude"], fix["longitude"]) == (site["latitude"], site["longitude"])
        assert {"key": "source", "value": site["source"]} in fix["metadata"]
        assert fix["position_covariance_type"] == rec.COVARIANCE_UNKNOWN
    assert fixes[0]["altitude"] == 612.5 and sites[0]["source"] == "config"
    assert log.metadata["site"] == {"station": stations[0]} | rec.site_metadata(sites[0])
    assert log.metadata["site"]["latitude"] == "40.331"

    said = [doc["message"] for doc in log.on(rec.LOG)]
    for station in stations[:2]:
        assert any(f"choice by tester at {station}: target 1 chosen" in t for t in said), said
    halted = said.index(f"station {stations[2]} incomplete: halted by tester")
    assert said.index("HALT from tester") < halted
    assert f"station {stations[3]} incomplete: cancelled by tester" in said


async def test_replay_drives_the_keypad_view_to_the_recorded_result(
    start_daemon, client: RigClient, router: str
) -> None:
    session, result, _ = await _surveyed(start_daemon, client)
    link = Transport("client", connect=(router,))
    with RigClient.open(link, "replayed", "viewer") as viewer:
        async with RigWatch(viewer).following() as view:
            # The view's subscriptions reach the router in their own time (on a loaded
            # machine, after a short replay is over): replay again until it has seen one.
            async with asyncio.timeout(90):
                while view.result is None or len(view.chips) < 3:
                    count = await replay(session / "session.mcap", link, "replayed", speed=20.0)
                    assert count > 0
                    await asyncio.sleep(0.5)
    assert view.result == result
    assert {c.rank for c in view.chips.values()} == {1, 2, 3}
    assert view.progress is not None and view.progress.stage == "done"


async def test_a_killed_daemon_leaves_a_readable_log(start_daemon, client: RigClient) -> None:
    """SIGKILL mid-session (a station done, the session open): the log reads up to its
    last whole chunk, which by then holds the station's progress at least."""
    daemon = await start_daemon()
    await client.wait_alive()
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    await client.command(TakeControl())
    station = (await client.command(SurveyStart(rows=2, cols=3))).detail
    async with asyncio.timeout(60):
        while (await progress.get()).stage != "done":
            pass
    daemon.proc.send_signal(signal.SIGKILL)
    await asyncio.wait_for(daemon.proc.wait(), 10)
    log = Path(daemon.ready["archive"]) / station.split("/")[0] / "session.mcap"
    metadata, messages = read_log(log)
    assert metadata["session"]["rig"] == "itest"
    assert messages and all(json.loads(m.data) is not None for m in messages)
    assert {m.topic for m in messages} >= {rec.TOPICS["survey.progress"], rec.TOPICS["ptu.state"]}
