"""Where the rig stood: a real gpsd-speaking socket feeds :class:`Gpsd`, and a station's
site record takes a fresh fix over the configuration."""

from __future__ import annotations

import asyncio
import json

from cyborg.daemon.survey.site import Gpsd, Orientation, SiteConfig, where

TPV = {"class": "TPV", "mode": 3, "lat": 40.3312, "lon": -3.5171, "altHAE": 612.5, "time": "t"}


async def test_a_gpsd_fix_overrides_the_configured_site() -> None:
    watched = asyncio.Event()

    async def gpsd(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        assert (await reader.readline()).startswith(b"?WATCH=")
        watched.set()
        for line in (b"not json\n", b'{"class":"VERSION"}\n', b'{"class":"TPV","mode":1}\n'):
            writer.write(line)  # noise, another class, no fix yet: all ignored
        writer.write(json.dumps(TPV).encode() + b"\n")
        await writer.drain()
        await reader.read()  # until the client goes

    server = await asyncio.start_server(gpsd, "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]
    client = Gpsd(f"127.0.0.1:{port}")
    task = asyncio.create_task(client.run())
    try:
        async with asyncio.timeout(10):
            await watched.wait()
            while client.position() is None:
                await asyncio.sleep(0.01)
    finally:
        task.cancel()
        await asyncio.gather(task, return_exceptions=True)
        server.close()
        await server.wait_closed()
    site = SiteConfig(name="Rio Tinto", latitude=1.0, longitude=2.0, heading=90.0)
    record = where(site, client)
    assert (record["latitude"], record["longitude"], record["altitude"]) == (
        40.3312,
        -3.5171,
        612.5,
    )
    assert record["source"] == f"gpsd 127.0.0.1:{port}" and record["name"] == "Rio Tinto"


def test_without_a_fix_the_configuration_says_where() -> None:
    site = SiteConfig(latitude=40.0, longitude=-3.0, heading=350.0, level=-1.5)
    record = where(site, Gpsd("127.0.0.1:1"))  # never connected: no fix
    assert (record["latitude"], record["source"]) == (40.0, "config")
    assert where(SiteConfig(), None)["source"] == "unknown"
    head = Orientation(site.heading, site.level)
    assert (head.azimuth(20.0), head.elevation(3.0)) == (10.0, 1.5)
