"""Aims of study (protocol 2.5) through a real daemon: the aim a station is asked for (or
keeps, or takes from ``[survey] aim``) reaches its analysis's parameters and is recorded in
its manifest, its result, the session log, the report and the export."""

from __future__ import annotations

import asyncio
import csv
import json
from pathlib import Path

import pytest
from test_cli import cyborg

from cyborg.clients.replay import read_log
from cyborg.clients.rigclient import RigClient, run_station
from cyborg.protocol import recording as rec
from cyborg.protocol.envelope import encode
from cyborg.protocol.messages import (
    ChooseTarget,
    InterestResult,
    SurveyProgress,
    SurveyStart,
    SurveyStatus,
    TakeControl,
)

pytestmark = pytest.mark.timeout(240)


def _recorded(archive: Path, station: str) -> tuple[str, str]:
    """(the manifest's plan aim, the aim result.json's params say the analysis ran with)."""
    manifest = json.loads((archive / station / "manifest.json").read_text())
    result = json.loads((archive / station / "analysis" / "result.json").read_text())
    return manifest["plan"]["aim"], result["params"]["aim"]


async def test_a_station_seeks_the_aim_asked_for_and_the_approach_keeps_it(
    daemon, client: RigClient, router: str, tmp_path: Path
) -> None:
    await client.wait_alive()
    archive = Path(daemon.ready["archive"])
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    await client.command(TakeControl())
    assert (await client.call(SurveyStatus())).aim == "any"  # nothing configured

    # An unknown aim on the wire is a protocol error naming the kinds; an aim smuggled in as
    # a setting is refused (one aim per station, recorded once); neither opens a station.
    reply = await client.call_raw(
        "survey/start", encode("survey.start", {"aim": "wet"}, src="tester")
    )
    assert reply.result == "ERROR" and "kinds: any, dark, bright, colour" in reply.detail
    reply = await client.call(SurveyStart(rows=1, cols=2, settings=("aim=dark",)))
    assert reply.result == "REJECTED" and "--aim" in reply.detail, reply
    assert (await client.call(SurveyStatus())).station == ""

    first = await run_station(
        client, progress, results, SurveyStart(rows=1, cols=2, aim="no-vegetation+dark")
    )
    assert first.aim == "dark+no-vegetation"  # canonical
    assert _recorded(archive, first.station) == ("dark+no-vegetation", "dark+no-vegetation")
    assert (await client.call(SurveyStatus())).aim == "dark+no-vegetation"

    # The approach's next leg, started without an aim, keeps the one the scientist set.
    await client.command(ChooseTarget(first.station, 1))
    second = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    assert second.aim == "dark+no-vegetation"
    assert _recorded(archive, second.station) == ("dark+no-vegetation", "dark+no-vegetation")

    # A survey again from the script client, with a new aim: taken for that station.
    code, out, _ = await cyborg(
        router, "survey", "--rows", "1", "--cols", "2", "--aim", "any", "--take"
    )
    assert code == 0 and out["aim"] == "any", out
    assert _recorded(archive, out["station"]) == ("any", "any")

    session = first.station.split("/")[0]
    report = (archive / session / "report.html").read_text()
    assert "aim: dark (dark features: wet stains" in report and "set aside: no-vegetation" in report
    table = tmp_path / "points.csv"
    code, _, _ = await cyborg(router, "export", session, "-o", str(table))
    assert code == 0
    with table.open() as f:
        by_station = {row["station"]: row["aim"] for row in csv.DictReader(f)}
    assert sorted(by_station.values()) == ["any", "dark+no-vegetation", "dark+no-vegetation"]

    await asyncio.sleep(0.5)
    assert await daemon.stop() == 0
    _, messages = read_log(archive / session / "session.mcap")
    logged = [json.loads(m.data)["aim"] for m in messages if m.topic == rec.TOPICS["survey.result"]]
    assert logged == ["dark+no-vegetation", "dark+no-vegetation", "any"]


async def test_the_rig_s_configured_aim_applies_when_none_is_asked(
    start_daemon, client: RigClient
) -> None:
    daemon = await start_daemon(aim="no-sky+bright")
    await client.wait_alive()
    assert (await client.call(SurveyStatus())).aim == "bright+no-sky"
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    await client.command(TakeControl())
    result = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    assert result.aim == "bright+no-sky"
    archive = Path(daemon.ready["archive"])
    assert _recorded(archive, result.station) == ("bright+no-sky", "bright+no-sky")
