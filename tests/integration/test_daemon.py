"""cyborgd as a real process: surveys over zenoh, hostile input, control, shutdown, crashes."""

from __future__ import annotations

import asyncio
import json
import os
import signal
from pathlib import Path

import cv2
import msgpack
import numpy as np
import pytest

from cyborg.clients.rigclient import RigClient, RigError, run_station, until_stage
from cyborg.clients.watch import RigWatch
from cyborg.daemon.camera.simulated import outcrop_panorama
from cyborg.protocol.envelope import decode, encode
from cyborg.protocol.messages import (
    Ack,
    ArchiveData,
    ArchiveGet,
    ArchiveList,
    ArchiveListing,
    Chip,
    ChooseTarget,
    Event,
    Hello,
    InterestResult,
    PtuGoto,
    PtuHalt,
    PtuLook,
    PtuState,
    ReleaseControl,
    Status,
    SurveyProgress,
    SurveyStart,
    SurveyStatus,
    TakeControl,
)
from cyborg.protocol.transport import Transport
from cyborg.protocol.version import PROTOCOL_MAJOR, PROTOCOL_MINOR

pytestmark = pytest.mark.timeout(120)


async def _state(client: RigClient, queue: asyncio.Queue, still: bool = True) -> PtuState:
    """The next PTU state (the next one standing still, by default)."""
    async with asyncio.timeout(15):
        while True:
            state = await queue.get()
            if not still or not state.moving:
                return state


async def _arrive(client: RigClient, queue: asyncio.Queue, pan: float, tilt: float) -> None:
    """Wait for the head to stand still at (pan, tilt): states published before the command
    took effect may still be queued, so one look at the queue is not enough."""
    state = await _state(client, queue)
    while (state.pan, state.tilt) != pytest.approx((pan, tilt), abs=0.06):
        state = await _state(client, queue)


def _manifest(archive: Path, station: str) -> dict:
    return json.loads((archive / station / "manifest.json").read_text())


def _check_consistent(archive: Path, station: str) -> dict:
    """Every file the manifest lists is whole; nothing half-written lies around."""
    m = _manifest(archive, station)
    folder = archive / station
    for rel, size in m["files"].items():
        assert (folder / rel).stat().st_size == size, rel
    leftovers = [p for p in folder.rglob(".*") if p.name != "manifest.json"]
    assert leftovers == []
    return m


async def test_full_survey_over_the_bus(daemon, client: RigClient, tmp_path: Path) -> None:
    await client.wait_alive()
    archive = Path(daemon.ready["archive"])
    alive = client.alive()
    assert await asyncio.wait_for(alive.get(), 10) is True
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    chips = client.subscribe(client.keys.chip, Chip)
    frames = client.frames()
    hello = await client.call(Hello(PROTOCOL_MAJOR, 0))
    assert isinstance(hello, Hello) and hello.rig == "itest" and hello.major == PROTOCOL_MAJOR
    frame = await asyncio.wait_for(frames.get(), 10)
    image = cv2.imdecode(np.frombuffer(frame.jpeg, np.uint8), cv2.IMREAD_COLOR)
    assert image.shape == (576, 720, 3) and frame.header.width == 720

    await client.command(TakeControl())
    result = await run_station(client, progress, results, SurveyStart(rows=2, cols=3))
    assert len(result.points) == 3 and (result.width, result.height) == (540, 288)
    # The planted targets are known in world angles: the best points land on them.
    targets = outcrop_panorama(3).targets
    hits = [min(np.hypot(p.pan - t.pan, p.tilt - t.tilt) for t in targets) for p in result.points]
    assert min(hits) < 0.5, hits

    m = _check_consistent(archive, result.station)
    assert m["status"] == "complete" and m["distance_m"] == 300
    assert len(m["tiles"]) == 6 and len(m["chips"]) == 3
    for tile in m["tiles"]:  # each tile was shot where the plan put it
        col, row = tile["col"], tile["row"]
        assert tile["pan"] == pytest.approx(-30 + 30 * col, abs=0.06)
        assert abs(tile["tilt"]) > 5 and (tile["tilt"] > 0) == (row == 0)
    for chip, point in zip(m["chips"], result.points, strict=True):
        assert (chip["pan"], chip["tilt"]) == pytest.approx((point.pan, point.tilt), abs=0.06)
    chip = await asyncio.wait_for(chips.get(), 5)
    assert chip.jpeg[:2] == b"\xff\xd8" and chip.product.startswith("chips/")

    session = result.station.split("/")[0]
    listing = await client.call(ArchiveList())
    assert isinstance(listing, ArchiveListing) and session in listing.items
    products = await client.call(ArchiveList(session))
    station = result.station.split("/")[1]
    assert f"{station}/analysis/overlay.png" in products.items
    assert f"{station}/tiles/r1c0.png" in products.items
    data = await client.call(ArchiveGet(session, f"{station}/analysis/overlay.png"))
    assert isinstance(data, ArchiveData)
    assert data.data == (archive / result.station / "analysis/overlay.png").read_bytes()
    for bad in ("../../etc/passwd", f"{station}/manifest.json/..", "nope.png", ".hidden"):
        reply = await client.call(ArchiveGet(session, bad))
        assert isinstance(reply, Ack) and reply.result == "REJECTED"

    # Clicks: a mosaic pixel re-points at what it shows; a live pixel too, from its frame's pose.
    states = client.subscribe(client.keys.ptu_state, PtuState)
    best = result.points[0]
    await client.command(  # point x, y index pixels; their centres are at +0.5
        PtuLook((best.x + 0.5) / result.width, (best.y + 0.5) / result.height, result.station),
    )
    await _arrive(client, states, best.pan, best.tilt)
    await client.command(PtuLook(1.0, 0.5, pan=0.0, tilt=0.0))
    await _arrive(client, states, 15.0, 0.0)  # the edge of 30 deg
    reply = await client.call(PtuLook(0.5, 0.5, f"{session}/st99-1m"))
    assert isinstance(reply, Ack) and reply.result == "REJECTED" and "st99" in reply.detail

    # The approach loop: choosing target 1 aims the next station at it, 60 m away.
    ack = await client.command(ChooseTarget(result.station, 1))
    assert "60 m" in ack.detail
    second = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    m2 = _manifest(archive, second.station)
    assert m2["distance_m"] == 60 and m2["aim"]["from"] == f"{result.station}#1"
    assert m2["plan"]["pan0"] == pytest.approx(result.points[0].pan)
    assert m2["plan"]["camera"]["hfov"] == pytest.approx(6.135, abs=0.01)  # 5x closer
    assert _manifest(archive, result.station)["choice"]["rank"] == 1


async def test_malformed_and_wrong_version_requests_get_error_acks(
    daemon, client: RigClient
) -> None:
    await client.wait_alive()
    states = client.subscribe(client.keys.ptu_state, PtuState, maxsize=1)
    await client.command(TakeControl())
    before = await _state(client, states)
    hostile: dict[str, bytes] = {
        "garbage": b"\xc1\xff not msgpack",
        "empty": b"",
        "a list": msgpack.packb([1, 2, 3]),
        "wrong kind": encode("ptu.halt", {}, src="tester"),
        "wrong type": encode("ptu.goto", {"pan": "ten", "tilt": 0.0}, src="tester"),
        "out of range": encode("ptu.goto", {"pan": 1e9, "tilt": 0.0}, src="tester"),
        "not finite": encode("ptu.goto", {"pan": float("nan"), "tilt": 0.0}, src="tester"),
        "missing field": encode("ptu.goto", {"pan": 1.0}, src="tester"),
    }
    for what, payload in hostile.items():
        reply = await client.call_raw("ptu/goto", payload)
        assert isinstance(reply, Ack) and reply.result == "ERROR", what
        assert reply.detail.startswith("ptu/goto:"), (what, reply.detail)
    # Over the protocol's size limit: the link drops it as its fragments arrive, before it
    # is whole in the daemon's memory, so no answer comes (our own clients refuse to send it).
    oversized = encode("ptu.goto", {"pan": 1.0, "tilt": 0.0, "pad": b"x" * (9 << 20)})
    with pytest.raises(RigError, match="Timeout"):
        await client.call_raw("ptu/goto", oversized, timeout=3.0)
    with pytest.raises(ValueError, match="over the protocol's"):
        await client.call(Hello(PROTOCOL_MAJOR, PROTOCOL_MINOR, "x" * (9 << 20)))
    # A 1.x client is told, in plain text any version can read, to update.
    v1 = encode("ptu.goto", {"pan": 10.0, "tilt": 0.0}, src="tester").replace(
        b"\xa1v\x02", b"\xa1v\x01"
    )
    with pytest.raises(RigError, match="protocol 2 required"):
        await client.call_raw("ptu/goto", v1)
    # A 64 KiB unknown kind is answered with a short error the client can decode.
    reply = await client.call_raw("ptu/goto", encode("x" * 65_000, {}, src="tester"))
    assert reply.result == "ERROR" and len(reply.detail) < 200
    # Beyond the unit's own limits: refused before anything is sent.
    reply = await client.call(PtuGoto(200.0, 0.0))
    assert reply.result == "LIMIT" and "outside the soft limits" in reply.detail
    after = await _state(client, states)
    assert (after.pan, after.tilt) == (before.pan, before.tilt)
    # ...and the daemon is fine.
    assert isinstance(await client.call(SurveyStatus()), Status)
    await client.command(PtuGoto(5.0, -2.0))
    state = await _state(client, states)
    while abs(state.pan - 5.0) > 0.06:
        state = await _state(client, states)
    assert state.tilt == pytest.approx(-2.0, abs=0.06)


async def test_a_survey_s_settings_are_checked_before_anything_moves(
    daemon, client: RigClient
) -> None:
    """2.2: a remote operator may try a parameter for one station (``cyborg survey --set``);
    a malformed setting is a protocol error, a mistyped or out-of-range one is refused by
    name, and neither moves the head or opens a station."""
    await client.wait_alive()
    states = client.subscribe(client.keys.ptu_state, PtuState, maxsize=1)
    await client.command(TakeControl())
    before = await _state(client, states)
    malformed = encode("survey.start", {"settings": ["blur"]}, src="tester")
    reply = await client.call_raw("survey/start", malformed)
    assert reply.result == "ERROR" and "is not NAME=VALUE" in reply.detail
    for bad, why in (
        ("blurr=8", "unknown parameter 'blurr' (did you mean blur?)"),
        ("top_n=many", "top_n: cannot read 'many' as int"),
    ):
        reply = await client.call(SurveyStart(rows=1, cols=2, settings=(bad,)))
        assert reply.result == "REJECTED", reply
        assert reply.detail == f"survey/start: settings: {why}"
    status = await client.call(SurveyStatus())
    assert status.state == "idle" and status.station == ""
    after = await _state(client, states)
    assert (after.pan, after.tilt) == (before.pan, before.tilt)
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    request = SurveyStart(rows=1, cols=2, settings=("top_n=1",))
    result = await run_station(client, progress, results, request)
    assert len(result.points) == 1


async def test_control_one_client_at_a_time(
    daemon, client: RigClient, other_client: RigClient
) -> None:
    await client.wait_alive()
    await other_client.wait_alive()
    events = client.subscribe(client.keys.events, Event)
    reply = await other_client.call(PtuGoto(3.0, 0.0))
    assert reply.result == "REJECTED" and "control/take" in reply.detail
    await client.command(TakeControl())
    reply = await other_client.call(PtuGoto(3.0, 0.0))
    assert reply.result == "REJECTED" and "held by tester" in reply.detail
    reply = await other_client.call(SurveyStart())
    assert reply.result == "REJECTED"
    reply = await other_client.call(ReleaseControl())
    assert reply.result == "REJECTED"
    # Halt always works, whoever sends it.
    assert (await other_client.call(PtuHalt())).ok
    # Take-over is explicit, and the previous holder hears about it.
    await other_client.command(TakeControl())
    async with asyncio.timeout(5):
        while True:
            event: Event = await events.get()
            if "intruder took control from tester" in event.text:
                break
    reply = await client.call(PtuGoto(3.0, 0.0))
    assert reply.result == "REJECTED"
    assert (await other_client.call(PtuGoto(3.0, 0.0))).ok
    status = await client.call(SurveyStatus())
    assert status.controller == "intruder"


async def _raw(client: RigClient, key: str, payload: bytes) -> Ack:
    """A query on any key, bypassing the client library's own name checks."""
    replies = await asyncio.to_thread(
        lambda: list(client.session.get(key, payload=payload, timeout=5.0))
    )
    assert replies and replies[0].ok is not None, key
    env = decode(replies[0].ok.payload.to_bytes())
    return Ack.from_body(env.body)


async def test_identity_is_the_key_and_names_are_checked(
    daemon, client: RigClient, other_client: RigClient
) -> None:
    """The caller is the key's client segment: an envelope claiming someone else is refused,
    and so is a name that is not a short printable identifier."""
    await client.wait_alive()
    events = client.subscribe(client.keys.events, Event)
    await client.command(TakeControl())
    # intruder's key, tester's name in the envelope: refused, the holder keeps control.
    forged = encode("ptu.goto", {"pan": 20.0, "tilt": -10.0}, src="tester")
    reply = await other_client.call_raw("ptu/goto", forged)
    assert reply.result == "REJECTED" and "speaks only for itself" in reply.detail
    # Nor can anyone take control on another's behalf.
    reply = await other_client.call(TakeControl("tester"))
    assert reply.result == "REJECTED"
    assert (await client.command(SurveyStatus())).controller == "tester"
    root = client.keys.root
    for name in ("bad\u202ename", "<b>x</b>", "a" * 4096, "tab\tname"):
        body = encode("control.take", {}, src=name)
        reply = await _raw(client, f"{root}/cmd/{name}/control/take", body)
        assert reply.result == "ERROR" and "client name" in reply.detail, name
        assert len(reply.detail) < 300
    assert (await client.command(SurveyStatus())).controller == "tester"
    # Every change of controller is announced.
    await client.command(ReleaseControl())
    texts = []
    async with asyncio.timeout(5):
        while "tester released control" not in texts:
            texts.append((await events.get()).text)
    assert "tester took control" in texts


async def test_sigterm_mid_survey_leaves_a_consistent_archive(daemon, client: RigClient) -> None:
    await client.wait_alive()
    archive = Path(daemon.ready["archive"])
    alive = client.alive()
    assert await asyncio.wait_for(alive.get(), 10) is True
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    await client.command(TakeControl())
    station = (await client.command(SurveyStart(rows=2, cols=3))).detail
    await until_stage(progress, station, {"tiles"})
    daemon.proc.send_signal(signal.SIGTERM)
    assert await asyncio.wait_for(daemon.proc.wait(), 20) == 0
    assert await asyncio.wait_for(alive.get(), 10) is False
    m = _check_consistent(archive, station)
    assert m["status"] == "incomplete" and "stopping" in m["reason"]
    assert 1 <= len(m["tiles"]) < 6
    log = daemon.log.read_text()
    assert "Traceback" not in log


async def test_worker_killed_mid_survey_fails_that_survey_only(
    start_daemon, client: RigClient
) -> None:
    daemon = await start_daemon()
    await client.wait_alive()
    archive = Path(daemon.ready["archive"])
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    events = client.subscribe(client.keys.events, Event)
    await client.command(TakeControl())
    status = await client.call(SurveyStatus())
    old_pid = status.worker_pid
    assert old_pid == daemon.ready["worker_pid"] != 0
    # Frozen before the survey starts (nothing asks the worker before the analysis), it cannot
    # finish the analysis before it is killed, however fast the analysis is.
    os.kill(old_pid, signal.SIGSTOP)
    station = (await client.command(SurveyStart(rows=2, cols=3))).detail
    await until_stage(progress, station, {"analysis"})
    os.kill(old_pid, signal.SIGKILL)
    final = await until_stage(progress, station, {"failed", "done"})
    assert final.stage == "failed"
    # Both events arrive, in either order: the station's failure and the worker's restart.
    texts: list[str] = []
    async with asyncio.timeout(10):
        while not (
            any("failed" in t and "worker" in t for t in texts)
            and any(f"pid {old_pid} died" in t and "restarted as pid" in t for t in texts)
        ):
            texts.append((await events.get()).text)
    m = _check_consistent(archive, station)
    assert m["status"] == "failed" and "worker" in m["reason"]
    assert not (archive / station / "analysis").exists()
    status = await client.call(SurveyStatus())
    assert status.worker_pid not in (0, old_pid) and "worker" in status.last_error
    # The next survey works.
    results = client.subscribe(client.keys.result, InterestResult)
    result = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    assert len(result.points) == 3
    assert daemon.proc.returncode is None


def _gone(pid: int) -> bool:
    """The process no longer runs (a zombie awaiting its reaper counts as gone)."""
    try:
        state = Path(f"/proc/{pid}/status").read_text()
    except FileNotFoundError:
        return True
    return "State:\tZ" in state


async def test_daemon_killed_mid_analysis_leaves_no_worker_and_an_incomplete_station(
    start_daemon, client: RigClient
) -> None:
    """SIGKILL gives the daemon no chance to clean up: the kernel takes its worker with it,
    and the restarted daemon marks the station incomplete and removes the partial analysis."""
    daemon = await start_daemon(downsample=1.0)
    await client.wait_alive()
    archive = Path(daemon.ready["archive"])
    worker = daemon.ready["worker_pid"]
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    await client.command(TakeControl())
    station = (await client.command(SurveyStart(rows=2, cols=3, downsample=1.0))).detail
    await until_stage(progress, station, {"analysis"})
    daemon.proc.send_signal(signal.SIGKILL)
    await asyncio.wait_for(daemon.proc.wait(), 10)
    async with asyncio.timeout(10):
        while not _gone(worker):
            await asyncio.sleep(0.05)
    again = await start_daemon()
    assert again.ready["recovered"] == [station]
    m = _check_consistent(archive, station)  # no .analysis.partial left either
    assert m["status"] == "incomplete"
    assert "BrokenPipe" not in daemon.log.read_text()


async def test_a_full_disk_fails_the_station_and_loses_nothing_written(
    start_daemon, client: RigClient, small_disk: Path
) -> None:
    world = {"camera": {"url": "sim://world?seed=3&hfov=30"}}  # no edge for 240 deg of pan
    daemon = await start_daemon(archive=small_disk / "archive", sections=world)
    await client.wait_alive()
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    events = client.subscribe(client.keys.events, Event)
    await client.command(TakeControl())
    request = SurveyStart(rows=2, cols=8, downsample=1.0)  # 16 tiles of ~1 MB each
    station = (await client.command(request)).detail
    final = await until_stage(progress, station, {"failed", "done"})
    assert final.stage == "failed"
    async with asyncio.timeout(10):
        while "No space left" not in (event := await events.get()).text:
            pass
    assert station in event.text
    m = _check_consistent(small_disk / "archive", station)
    assert m["status"] == "failed" and "No space left" in m["reason"]
    assert 0 < len(m["files"]) < 16
    # The daemon serves on, and says what went wrong.
    status = await client.command(SurveyStatus())
    assert "No space left" in status.last_error and daemon.proc.returncode is None


async def test_garbage_on_the_serial_line_does_not_break_a_survey(
    start_daemon, client: RigClient
) -> None:
    daemon = await start_daemon("&fault=garbage:PP:3&fault=garbage:TP:7&fault=garbage:PP:6")
    await client.wait_alive()
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    await client.command(TakeControl())
    result = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    assert len(result.points) == 3
    assert await daemon.stop() == 0
    assert daemon.log.read_text().count("injected fault: garbage") == 3  # they did strike


async def test_commands_without_a_daemon_fail_clearly(client: RigClient) -> None:
    with pytest.raises(RigError, match="no rig 'itest' answers"):
        await client.call(SurveyStatus(), timeout=1.0)
    with pytest.raises(RigError, match="not on the bus"):
        await client.wait_alive(timeout=0.3)


async def test_a_client_opened_mid_station_sees_the_points_awaiting_a_choice(
    daemon, client: RigClient, router: str
) -> None:
    """The keypad (its view) started after the result was published still shows the
    points the rig waits on: the status carries them."""
    await client.wait_alive()
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    await client.command(TakeControl())
    result = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
    with RigClient.open(Transport("client", connect=(router,)), "itest", "late") as late:
        async with RigWatch(late).following() as view:
            async with asyncio.timeout(10):
                while view.result is None:
                    await asyncio.sleep(0.05)
    assert view.result == result


async def test_streams_fit_the_link_each_subscriber_its_own(
    daemon, client: RigClient, other_client: RigClient
) -> None:
    """Two viewers ask for 2 and 10 fps at their own sizes: over the same window the first
    gets clearly fewer frames (a ratio, not a rate), each at the width it asked for."""
    await client.wait_alive()
    await other_client.wait_alive()
    slow_key = await client.stream(2.0, 320, 50)
    fast_key = await other_client.stream(10.0, 480, 70)
    assert slow_key != fast_key and slow_key.endswith("/cam/frame/2fps-320w-q50")
    slow = client.frames(maxsize=1000, key=slow_key)
    fast = other_client.frames(maxsize=1000, key=fast_key)
    await asyncio.sleep(3.0)
    n_slow, n_fast = slow.qsize(), fast.qsize()
    assert n_slow > 0 and n_fast >= 2 * n_slow, (n_slow, n_fast)
    small = cv2.imdecode(np.frombuffer(slow.get_nowait().jpeg, np.uint8), cv2.IMREAD_COLOR)
    large = cv2.imdecode(np.frombuffer(fast.get_nowait().jpeg, np.uint8), cv2.IMREAD_COLOR)
    assert small.shape[1] == 320 and large.shape[1] == 480
    # Out-of-range asks are refused by the request's own checks.
    reply = await client.call_raw(
        "cam/stream", encode("cam.stream.request", {"fps": 500.0}, src="tester")
    )
    assert reply.result == "ERROR" and "fps" in reply.detail
