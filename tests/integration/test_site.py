"""Where the rig was and which way it looked: a fake gpsd (its JSON protocol over TCP, as
gpsd speaks it) feeds a fix into the station's manifest; interest points carry azimuth and
elevation on the bus and in the manifest; ``cyborg export`` writes them as CSV and GeoJSON."""

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
from cyborg.protocol.messages import InterestResult, SurveyProgress, SurveyStart, TakeControl

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

    async def export(fmt: str) -> str:
        proc = await asyncio.create_subprocess_exec(
            sys.executable, "-m", "cyborg.clients", "export", session, "--format", fmt, "-o", "-",
            "--rig", "itest", "--connect", router, "--name", "exporter",
            stdout=asyncio.subprocess.PIPE,
        )  # fmt: skip
        out, _ = await proc.communicate()
        assert proc.returncode == 0
        return out.decode()

    geo = json.loads(await export("geojson"))
    assert geo["type"] == "FeatureCollection" and len(geo["features"]) == 3
    for feature, point in zip(geo["features"], manifest["points"], strict=True):
        assert feature["geometry"] == {"type": "Point", "coordinates": [-3.517, 40.331, 612.5]}
        assert feature["properties"]["azimuth"] == point["azimuth"]
        assert feature["properties"]["station"] == station
    rows = list(csv.DictReader(io.StringIO(await export("csv"))))
    assert [float(r["azimuth"]) for r in rows] == [p["azimuth"] for p in manifest["points"]]
    assert (
        rows[0]["site"] == "Rivas Vaciamadrid" and rows[0]["reason"] == manifest["points"][0]["why"]
    )
