"""``cyborg replay`` as a real process on a real router, asked by ``cyborg`` script commands
as real processes: the read-only commands answered as the rig did at that moment of the
recording, everything else refused, and the replay answering on after its end (or leaving,
with ``--once``). The session log is written by the daemon's own writer."""

from __future__ import annotations

import asyncio
import contextlib
import signal
import sys
import time
from collections.abc import AsyncIterator, Callable
from pathlib import Path

import numpy as np
import pytest
from test_cli import cyborg
from test_session_log import _surveyed

from cyborg.clients.rigclient import RigClient
from cyborg.daemon.record import SessionLog
from cyborg.daemon.vision.imageio import encode_image
from cyborg.protocol import recording as rec
from cyborg.protocol.messages import (
    Ack,
    Chip,
    Event,
    InterestPoint,
    InterestResult,
    Message,
    PtuGoto,
    PtuState,
    SurveyProgress,
)
from cyborg.protocol.transport import Transport

pytestmark = pytest.mark.timeout(180)

SESSION = "20260101-120000"
STATION = f"{SESSION}/st01-300m"


def station_result(station: str) -> InterestResult:
    """A station's result: #1 a target, #2 no further target (protocol 2.4)."""
    points = (
        InterestPoint(1, 40.0, 30.0, 4.3, -5.0, 2.0, "green patch on orange rock"),
        InterestPoint(2, 90.0, 50.0, 0.04, 7.0, -3.0, "faint speck", target=False),
    )
    return InterestResult(station, points, 180, 96)


MOSAIC = encode_image(np.full((96, 180, 3), 90, np.uint8), ".png")
CHIP = encode_image(np.full((48, 64, 3), 200, np.uint8))


def write_recording(folder: Path, gap_s: float, session: str = SESSION) -> Path:
    """A station's session log: its first tile, then ``gap_s`` later its analysis, a chip,
    its end and its result (:func:`station_result`) with the mosaic, as a daemon records
    them."""
    station = f"{session}/st01-300m"
    path = folder / session / "session.mcap"
    path.parent.mkdir(parents=True)
    log = SessionLog(path, {"rig": "demo", "build": "0.test", "session": session})
    t0 = time.time_ns()
    gap = int(gap_s * 1e9)

    def put(ns: int, msg: Message) -> None:
        log.put((rec.TOPICS[msg.KIND], rec.schema_name(msg.KIND), ns, rec.to_json(msg)))

    put(t0, PtuState(0.0, 0.0, False, controller="arm"))
    put(t0 + 1, SurveyProgress(station, "tiles", 1, 6, 30.0))
    put(t0 + gap, SurveyProgress(station, "analysis", 0, 1))
    chip = Chip(station, 1, -5.0, 2.0, "chips/chip1.png", CHIP)
    put(t0 + gap + 1, chip)
    image = rec.compressed_image(t0 + gap + 1, "camera", "jpeg", CHIP)
    log.put((rec.IMAGE_TOPICS["survey.chip"], "foxglove.CompressedImage", t0 + gap + 1, image))
    put(t0 + gap + 2, SurveyProgress(station, "done", 1, 1, 0.0))
    put(t0 + gap + 3, station_result(station))
    mosaic = rec.compressed_image(t0 + gap + 3, "mosaic", "png", MOSAIC)
    log.put((rec.MOSAIC, "foxglove.CompressedImage", t0 + gap + 3, mosaic))
    event = Event("info", f"station {station} complete: 2 interest points")
    log.put((rec.LOG, "foxglove.Log", t0 + gap + 4, rec.log_entry(t0 + gap + 4, event, "cyborgd")))
    log.close()
    return path


@pytest.fixture
def start_replay(router: str) -> Callable:
    """``cyborg replay LOG ARGS`` dialling the router, as a context: stopped at its end."""

    @contextlib.asynccontextmanager
    async def start(log: Path, *args: str) -> AsyncIterator[asyncio.subprocess.Process]:
        proc = await asyncio.create_subprocess_exec(
            sys.executable,
            *("-m", "cyborg.clients", "replay", str(log), "--connect", router, *args),
            stdout=asyncio.subprocess.PIPE,
            stderr=asyncio.subprocess.PIPE,
        )
        try:
            yield proc
        finally:
            if proc.returncode is None:
                proc.send_signal(signal.SIGINT)
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(proc.wait(), 10)
            if proc.returncode is None:
                proc.kill()
                await proc.wait()

    return start


async def at_end(proc: asyncio.subprocess.Process) -> None:
    """Until the replay says it has played its recording and answers on."""
    line = await asyncio.wait_for(proc.stdout.readline(), 60)
    assert b"until stopped" in line, line


async def _status_until(router: str, state: str) -> dict:
    """``cyborg status`` until the replay has come to ``state`` (it is on its way)."""
    async with asyncio.timeout(60):
        while True:
            code, status, err = await cyborg(router, "status", rig="demo")
            assert code == 0, err
            if status["state"] == state:
                return status
            await asyncio.sleep(0.2)


async def test_scripts_see_a_replay_mid_station(
    router: str, start_replay: Callable, tmp_path: Path
) -> None:
    """An hour between the first tile and the analysis: the replay stands mid-station."""
    log = write_recording(tmp_path, gap_s=3600)
    async with start_replay(log) as proc:
        status = await _status_until(router, "surveying")
        assert status["rig"] == "demo" and status["build"] == "replay of 0.test"
        assert status["station"] == STATION and status["distance_m"] == 300
        assert status["session"] == SESSION and status["controller"] == "arm"
        assert status["result"] is None

        code, sessions, _ = await cyborg(router, "list", rig="demo")
        assert code == 0 and sessions["items"] == [SESSION]
        code, products, _ = await cyborg(router, "list", SESSION, rig="demo")
        assert products["items"] == ["st01-300m/chips/chip1.png", "st01-300m/mosaic.png"]
        out = tmp_path / "mosaic.png"
        code, _, _ = await cyborg(
            router, "fetch", SESSION, "st01-300m/mosaic.png", "-o", str(out), rig="demo"
        )
        assert code == 0 and out.read_bytes() == MOSAIC
        code, missing, _ = await cyborg(router, "fetch", SESSION, "report.html", rig="demo")
        assert code == 1 and "not in the recording" in missing["error"]

        with RigClient.open(Transport("client", connect=(router,)), "demo", "tester") as c:
            goto = await c.call(PtuGoto(1.0, 2.0))
        assert goto == Ack("REJECTED", "replay: read-only, motion refused")
        code, _, err = await cyborg(router, "halt", rig="demo")
        assert code == 1 and "replay: read-only, ptu/halt refused" in err, err
        code, take, err = await cyborg(router, "take", rig="demo")
        assert code == 1 and take["result"] == "REJECTED", err
        assert proc.returncode is None


async def test_a_replay_answers_on_after_its_end(
    router: str, start_replay: Callable, tmp_path: Path
) -> None:
    log = write_recording(tmp_path, gap_s=0.2)
    async with start_replay(log, "--speed", "2") as proc:
        await at_end(proc)
        status = await _status_until(router, "awaiting-choice")
        assert status["result"]["station"] == STATION
        points = status["result"]["points"]
        assert [p["target"] for p in points] == [True, False]
        await asyncio.sleep(1.0)  # well past the end: still there, the head as it stood
        assert proc.returncode is None
        code, status, _ = await cyborg(router, "status", rig="demo")
        assert status["ptu"] == {
            "pan": 0.0,
            "tilt": 0.0,
            "moving": False,
            "link": "ready",
            "controller": "arm",
        }
        code, hello, _ = await cyborg(
            router, "call", "hello", '{"major": 2, "minor": 0}', rig="demo"
        )
        assert code == 0 and hello["rig"] == "demo"
        proc.send_signal(signal.SIGINT)
        assert await asyncio.wait_for(proc.wait(), 10) == 0


async def test_once_leaves_at_the_end(router: str, start_replay: Callable, tmp_path: Path) -> None:
    log = write_recording(tmp_path, gap_s=0.2)
    async with start_replay(log, "--once") as proc:
        assert await asyncio.wait_for(proc.wait(), 60) == 0
        out = await proc.stdout.read()
        assert b"replayed as rig demo" in out and b"until stopped" not in out


async def test_a_real_recording_answers_as_its_rig(
    start_daemon,
    client: RigClient,
    router: str,
    start_replay: Callable,
    tmp_path: Path,
) -> None:
    """A station surveyed by a real daemon, replayed: the status awaits a choice of the
    result the rig published, and the mosaic is the archived one, byte for byte."""
    session, result, _ = await _surveyed(start_daemon, client)
    async with start_replay(session, "--as-rig", "replayed", "--speed", "20") as proc:
        await at_end(proc)
        code, status, _ = await cyborg(router, "status", rig="replayed")
        assert code == 0 and status["state"] == "awaiting-choice"
        assert InterestResult.from_body(status["result"]) == result
        code, products, _ = await cyborg(router, "list", session.name, rig="replayed")
        name = result.station.split("/")[1]
        assert f"{name}/mosaic.png" in products["items"]
        out = tmp_path / "mosaic.png"
        code, _, _ = await cyborg(
            router, "fetch", session.name, f"{name}/mosaic.png", "-o", str(out), rig="replayed"
        )
        assert code == 0 and out.read_bytes() == (session / name / "mosaic.png").read_bytes()
