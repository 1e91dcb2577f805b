"""A power cut mid-station (the session's second), played by SIGKILL on a real daemon
whose camera URL carries credentials. Started again on the same archive, the daemon
recovers the log the cut left into a complete, indexed file holding every whole chunk,
which the mcap library's ordinary reader and ``cyborg replay`` read; the credentials are
nowhere in the archive or the daemon's log."""

from __future__ import annotations

import asyncio
import json
import signal
import sys
from pathlib import Path

import cv2
import pytest
from mcap.reader import make_reader

from cyborg.clients.replay import read_log
from cyborg.clients.rigclient import RigClient, run_station
from cyborg.daemon.camera import outcrop_panorama
from cyborg.protocol.messages import InterestResult, SurveyProgress, SurveyStart, TakeControl

pytestmark = pytest.mark.timeout(180)

SECRET = "s3cr3t-pw"


async def test_a_log_cut_mid_station_is_recovered_at_the_next_start(
    start_daemon, client: RigClient, router: str, tmp_path: Path
) -> None:
    pano = tmp_path / "pano.png"
    assert cv2.imwrite(str(pano), outcrop_panorama(3, pixels_per_degree=8.0).image)
    sections = {"camera": {"url": f"sim://viewer:{SECRET}@{pano}?hfov=30"}}
    archive = tmp_path / "archive"
    daemon = await start_daemon(archive=archive, sections=sections)
    await client.wait_alive()
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    await client.command(TakeControl())
    first = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    station = (await client.command(SurveyStart(rows=2, cols=3))).detail
    async with asyncio.timeout(60):
        while True:
            p = await progress.get()
            if p.station == station and p.stage == "tiles" and p.done >= 3:
                break
    daemon.proc.send_signal(signal.SIGKILL)
    await asyncio.wait_for(daemon.proc.wait(), 10)
    log = archive / station.split("/")[0] / "session.mcap"
    _, cut = read_log(log)  # the raw stream reader: the whole chunks the cut left

    again = await start_daemon(archive=archive, sections=sections)
    assert again.ready["recovered"] == [station]
    with log.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        messages = [(c.topic, m.log_time, m.data) for _, c, m in reader.iter_messages()]
        metadata = {m.name: m.metadata for m in reader.iter_metadata()}
    assert summary is not None and summary.statistics is not None and summary.chunk_indexes
    assert messages == [(m.topic, m.log_time, m.data) for m in cut]
    assert summary.statistics.message_count == len(messages)
    results_logged = [json.loads(data) for topic, _, data in messages if topic == "/survey/result"]
    assert [r["station"] for r in results_logged] == [first.station]  # the station before the cut
    assert metadata["session"]["camera"] == f"sim://***@{pano}?hfov=30"

    replay = await asyncio.create_subprocess_exec(
        *(sys.executable, "-m", "cyborg.clients", "replay", str(log.parent), "--connect", router),
        *("--as-rig", "replayed", "--speed", "50", "--once"),
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    out, err = await asyncio.wait_for(replay.communicate(), 120)
    assert replay.returncode == 0 and b"Traceback" not in err, err.decode()
    assert int(out.split()[2]) > 0, out  # "cyborg replay: N messages of ... replayed"

    await again.stop()
    leaks = [p for p in archive.rglob("*") if p.is_file() and SECRET.encode() in p.read_bytes()]
    assert leaks == []
    assert SECRET not in daemon.log.read_text(errors="replace")
