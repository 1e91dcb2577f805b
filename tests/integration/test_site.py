"""Where the rig was and which way it looked: a fake gpsd (its JSON protocol over TCP, as
gpsd speaks it) feeds a fix into the station's manifest; interest points carry azimuth and
elevation on the bus and in the manifest; ``cyborg export`` writes them as CSV and GeoJSON,
the stations along the walk when no fix says where they stood."""

from __future__ import annotations

import asyncio
import contextlib
import csv
import io
import json
import sys
from collections.abc import AsyncIterator
from pathlib import Path

import pytest

from cyborg.clients.rigclient import RigClient, run_station
from cyborg.protocol.messages import (
    ChooseTarget,
    InterestResult,
    SurveyProgress,
    SurveyStart,
    TakeControl,
)

pytestmark = pytest.mark.timeout(180)

TPV = {
    "class": "TPV",
    "device": "/dev/ttyACM0",
    "mode": 3,
    "time": "2026-11-23T10:00:00.000Z",
    "lat": 40.331,
    "lon": -3.517,
    "altHAE": 612.5,
}


@pytest.fixture
async def gpsd() -> AsyncIterator[str]:
    """A gpsd in miniature: VERSION on connect, then after ?WATCH a TPV a second (with a
    no-fix report and a line of noise first, as a receiver warming up gives)."""

    handlers: set[asyncio.Task] = set()

    async def client(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        handlers.add(asyncio.current_task())
        writer.write(b'{"class":"VERSION","release":"3.25","proto_major":3,"proto_minor":15}\n')
        line = await reader.readline()
        assert line.startswith(b"?WATCH=")
        writer.write(b'{"class":"TPV","mode":1}\nnot json\n')
        with contextlib.suppress(ConnectionError):
            while True:
                writer.write(json.dumps(TPV).encode() + b"\n")
                await writer.drain()
                await asyncio.sleep(0.2)

    server = await asyncio.start_server(client, "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]
    try:
        yield f"127.0.0.1:{port}"
    finally:
        server.close()
        for task in handlers:
            task.cancel()
        await asyncio.gather(*handlers, return_exceptions=True)


async def test_fix_heading_and_export(start_daemon, client: RigClient, gpsd: str, router: str):
    site = {"name": "Rivas Vaciamadrid", "heading": 350.0, "level": 0.5, "gpsd": gpsd}
    daemon = await start_daemon(sections={"site": site})
    await client.wait_alive()
    await asyncio.sleep(0.5)  # the first fix arrives
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    await client.command(TakeControl())
    result = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    for p in result.points:
        assert p.azimuth == pytest.approx((350.0 + p.pan) % 360.0, abs=1e-3)
        assert p.elevation == pytest.approx(p.tilt + 0.5, abs=1e-3)
    session, station = result.station.split("/")
    manifest = json.loads(
        (Path(daemon.ready["archive"]) / result.station / "manifest.json").read_text()
    )
    assert manifest["site"]["latitude"] == 40.331 and manifest["site"]["altitude"] == 612.5
    assert manifest["site"]["source"].startswith("gpsd") and manifest["site"]["heading"] == 350.0
    assert [p["azimuth"] for p in manifest["points"]] == [p.azimuth for p in result.points]

    geo = json.loads(await _export(router, session, "geojson"))
    assert geo["type"] == "FeatureCollection"
    kinds = [f["properties"]["feature"] for f in geo["features"]]
    assert kinds == ["station", "point", "point", "point"]  # one station: no walk
    here = {"type": "Point", "coordinates": [-3.517, 40.331, 612.5]}  # the fix
    assert geo["features"][0]["geometry"] == here
    assert geo["features"][0]["properties"]["source"].startswith("gpsd")
    for feature, point in zip(geo["features"][1:], manifest["points"], strict=True):
        lat, lon = point["position"]["latitude"], point["position"]["longitude"]
        assert feature["geometry"]["coordinates"][:2] == [lon, lat]  # its target, estimated
        assert feature["properties"]["located"] == "target"
        assert feature["properties"]["azimuth"] == point["azimuth"]
        assert feature["properties"]["station"] == station
    rows = list(csv.DictReader(io.StringIO(await _export(router, session, "csv"))))
    assert [float(r["azimuth"]) for r in rows] == [p["azimuth"] for p in manifest["points"]]
    assert (
        rows[0]["site"] == "Rivas Vaciamadrid" and rows[0]["reason"] == manifest["points"][0]["why"]
    )
    assert [float(r["target_latitude"]) for r in rows] == [
        p["position"]["latitude"] for p in manifest["points"]
    ]


async def test_three_stations_walked_export_along_the_walk(
    start_daemon, client: RigClient, router: str
) -> None:
    """A site and no gpsd, 300 -> 60 -> 10 m: the GeoJSON draws three stations along the
    walk (the first at the site, the others dead-reckoned), the walk as a line, and each
    point at its target's estimated place; the CSV says the same."""
    site = {"name": "Rivas", "latitude": 40.331, "longitude": -3.517, "heading": 350.0}
    await start_daemon(sections={"site": site})
    await client.wait_alive()
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    await client.command(TakeControl())
    for leg in range(3):
        result = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
        if leg < 2:
            await client.command(ChooseTarget(result.station, 1))
    session = result.station.split("/")[0]
    geo = json.loads(await _export(router, session, "geojson"))
    by_kind: dict[str, list[dict]] = {}
    for feature in geo["features"]:
        by_kind.setdefault(feature["properties"]["feature"], []).append(feature)
    stations = by_kind["station"]
    assert [s["properties"]["source"] for s in stations] == ["config", *["dead-reckoned"] * 2]
    assert stations[0]["geometry"]["coordinates"] == [-3.517, 40.331]
    places = [s["geometry"]["coordinates"] for s in stations]
    assert len({tuple(p) for p in places}) == 3  # three places, not one
    assert [s["properties"]["leg"]["distance_m"] for s in stations[1:]] == [240.0, 50.0]
    assert by_kind["walk"][0]["geometry"] == {"type": "LineString", "coordinates": places}
    points = by_kind["point"]
    assert points and all(p["properties"]["located"] == "target" for p in points)
    rows = list(csv.DictReader(io.StringIO(await _export(router, session, "csv"))))
    assert len(rows) == len(points)
    assert {(r["station_source"], r["longitude"], r["latitude"]) for r in rows} == {
        (s["properties"]["source"], *map(str, s["geometry"]["coordinates"])) for s in stations
    }


async def _export(router: str, session: str, fmt: str) -> str:
    """``cyborg export`` of a session to stdout, as a user runs it."""
    proc = await asyncio.create_subprocess_exec(
        sys.executable, "-m", "cyborg.clients", "export", session, "--format", fmt, "-o", "-",
        "--rig", "itest", "--connect", router, "--name", "exporter",
        stdout=asyncio.subprocess.PIPE,
    )  # fmt: skip
    out, _ = await proc.communicate()
    assert proc.returncode == 0
    return out.decode()
