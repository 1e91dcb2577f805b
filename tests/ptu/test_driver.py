"""The serial driver against the emulator over a real pseudo-terminal."""

from __future__ import annotations

import asyncio
import os
import signal
import sys
from pathlib import Path

import pytest

from cyborg.daemon.ptu import (
    BANNER,
    EmulatedPtu,
    LinkState,
    PtuCommandError,
    PtuConnectionError,
    PtuIllegalCommandError,
    PtuLimitError,
    PtuSpeedError,
    PtuTimeoutError,
    PtyPtu,
    SerialPtu,
    open_ptu,
)
from cyborg.daemon.ptu.emulator import Ptu46Emulator
from cyborg.daemon.ptu.models import MODELS
from cyborg.daemon.ptu.ptyserver import Fault

pytestmark = pytest.mark.timeout(60)


async def test_connect_queries_the_unit(ptu: PtyPtu) -> None:
    emu = ptu.server.emulator
    assert ptu.state is LinkState.READY
    assert (emu.echo, emu.verbose, emu.immediate) == (False, False, True)
    info = ptu.info
    assert (info.pan.min_pos, info.pan.max_pos, info.tilt.min_pos, info.tilt.max_pos) == (
        -3090,
        3090,
        -907,
        604,
    )
    assert info.pan.resolution == 185.1428
    assert (info.pan.base, info.pan.upper, info.pan.lower, info.pan.accel) == (1000, 2902, 31, 2000)
    assert info.limits_enabled
    assert "Directed Perception" in info.version
    assert info.pan.max_deg == pytest.approx(158.91, abs=0.01)


async def test_other_model_is_queried_not_assumed() -> None:
    async with PtyPtu(Ptu46Emulator(MODELS["46-70"], time_scale=20), baud=0) as unit:
        assert unit.info.pan.resolution == 46.2857
        assert unit.info.pan.max_pos == 12360
        await unit.move_to(10.0, -5.0)
        here = await unit.position()
        assert here.pan == pytest.approx(10.0, abs=0.013)
        assert here.tilt == pytest.approx(-5.0, abs=0.013)


async def test_banner_and_echo_on_at_power_up() -> None:
    async with PtyPtu(Ptu46Emulator(time_scale=20), banner=BANNER) as unit:
        assert unit.state is LinkState.READY
        assert not unit.server.emulator.echo


async def test_moves_in_degrees(ptu: PtyPtu) -> None:
    here = await ptu.move_to(30.0, -10.0)
    assert (here.pan, here.tilt) == pytest.approx((30.0, -10.0), abs=0.026)
    assert not here.moving
    emu = ptu.server.emulator
    assert (emu.pan.position, emu.tilt.position) == (here.pan_pos, here.tilt_pos)
    here = await ptu.move_by(pan=-5.0)
    assert here.pan == pytest.approx(25.0, abs=0.052)
    assert here.tilt == pytest.approx(-10.0, abs=0.026)
    here = await ptu.move_to(tilt=5.0)
    assert here.pan == pytest.approx(25.0, abs=0.052)


async def test_soft_limits_checked_before_sending(ptu: PtyPtu) -> None:
    seen = ptu.server.emulator.commands_seen
    with pytest.raises(PtuLimitError, match="outside the soft limits"):
        await ptu.move_to(170.0, 0.0)
    with pytest.raises(PtuLimitError):
        await ptu.move_to(0.0, -50.0)
    with pytest.raises(ValueError):
        await ptu.move_to(float("nan"))
    assert ptu.server.emulator.commands_seen == seen


async def test_unit_refusals_become_typed_errors(ptu: PtyPtu) -> None:
    with pytest.raises(PtuIllegalCommandError, match="Illegal Command"):
        await ptu._do("XYZ")
    with pytest.raises(PtuLimitError, match="Maximum allowable Pan position is 3090"):
        await ptu._do("PP", 4000)
    with pytest.raises(PtuSpeedError, match="cannot exceed 2902"):
        await ptu._do("PS", 5000)
    with pytest.raises(PtuSpeedError, match="less than 31"):
        await ptu._do("TS", 3)
    with pytest.raises(PtuSpeedError, match="outside"):  # checked before sending
        await ptu.set_speed(pan=200.0)
    await ptu.move_to(100.0, wait=False)
    with pytest.raises(PtuSpeedError, match="while the axis is moving"):
        await ptu.set_acceleration(pan=50.0)
    with pytest.raises(PtuCommandError, match="Unit ID"):
        await ptu._do("U", 500)
    await ptu.wait_motion()
    assert ptu.state is LinkState.READY


async def test_speed_and_acceleration_change_the_move(ptu: PtyPtu) -> None:
    await ptu.set_speed(pan=120.0, tilt=40.0)
    await ptu.set_acceleration(pan=150.0)
    emu = ptu.server.emulator
    assert emu.pan.motion.speed == round(120.0 / (185.1428 / 3600))
    assert emu.pan.motion.accel == round(150.0 / (185.1428 / 3600))
    assert ptu.info.pan.speed == emu.pan.motion.speed
    fast = ptu.predict_move_time(pan=100.0)
    await ptu.set_speed(pan=30.0)
    assert ptu.predict_move_time(pan=100.0) > 2 * fast


async def test_echo_and_verbose_switched_back_on(ptu: PtyPtu) -> None:
    await ptu.move_to(12.0, 3.0)
    emu = ptu.server.emulator
    emu.echo = emu.verbose = True
    here = await ptu.position()
    assert (here.pan_pos, here.tilt_pos) == (emu.pan.position, emu.tilt.position)
    await ptu.move_to(-12.0, 0.0)
    assert (await ptu.position()).pan == pytest.approx(-12.0, abs=0.026)


async def test_garbage_and_banner_are_skipped(ptu: PtyPtu) -> None:
    await ptu.move_to(20.0, 5.0)
    garbage = Fault("garbage", "PP", count=0)
    ptu.server.faults.append(garbage)
    ptu.server.inject(BANNER)
    for _ in range(5):
        here = await ptu.position()
        assert here.pan_pos == ptu.server.emulator.pan.position
    assert garbage.fired == 5
    ptu.server.inject(b"\xff\xfe" * 400 + b"\r\n~junk\r\n")
    assert (await ptu.position()).tilt_pos == ptu.server.emulator.tilt.position


async def test_dropped_reply_is_resynced_and_retried(ptu: PtyPtu) -> None:
    ptu.command_timeout = 0.3
    drop = Fault("drop", "PP")
    ptu.server.faults.append(drop)
    here = await ptu.position()
    assert drop.fired == 1
    assert (ptu.resyncs, ptu.retried) == (1, 1)
    assert here.pan_pos == ptu.server.emulator.pan.position
    # A unit that never answers PP: bounded retries, then the timeout.
    ptu.server.faults.append(always := Fault("drop", "PP", count=0))
    with pytest.raises(PtuTimeoutError, match="no reply to PP"):
        await ptu.position()
    assert always.fired == 1 + ptu.retries
    assert ptu.state is LinkState.READY
    ptu.server.faults.remove(always)
    here = await ptu.position()
    assert here.pan_pos == ptu.server.emulator.pan.position


async def test_slow_replies(ptu: PtyPtu) -> None:
    ptu.command_timeout = 0.5
    slow, slower = Fault("delay", "TP", seconds=0.2), Fault("delay", "TP", seconds=0.6)
    ptu.server.faults.append(slow)
    assert (await ptu.position()).tilt_pos == 0
    assert slow.fired == 1
    ptu.server.faults.append(slower)
    assert (await ptu.position()).tilt_pos == 0  # timed out, resynchronised, asked again
    assert (slower.fired, ptu.retried) == (1, 1)
    await ptu.move_to(0.0, 10.0)  # the late reply was drained: it answers nothing
    assert (await ptu.position()).tilt_pos == ptu.server.emulator.tilt.position


async def test_hangup_mid_move_and_reconnect(ptu: PtyPtu) -> None:
    await ptu.move_to(120.0, wait=False)
    await asyncio.sleep(0.05)
    ptu.server.hangup(0.4)
    with pytest.raises(PtuConnectionError):
        for _ in range(20):
            await ptu.position()
            await asyncio.sleep(0.01)
    assert ptu.state is LinkState.DISCONNECTED
    await ptu.wait_ready(10.0)
    assert ptu.reconnects == 1
    # The head kept moving while the link was down; the driver finds it where it is.
    here = await ptu.wait_motion()
    assert here.pan == pytest.approx(120.0, abs=0.026)


async def test_hangup_fault_as_data() -> None:
    hangup = Fault("hangup", "A", seconds=0.3)
    unit = PtyPtu(Ptu46Emulator(time_scale=20), baud=0, faults=[hangup])
    async with unit:
        with pytest.raises(PtuConnectionError):
            await unit._do("A")
        assert hangup.fired == 1
        await unit.wait_ready(10.0)
        assert (await unit.move_to(5.0, 5.0)).pan == pytest.approx(5.0, abs=0.026)


async def test_halt_mid_move(ptu: PtyPtu) -> None:
    await ptu.move_to(150.0, wait=False)
    await asyncio.sleep(0.05)
    await ptu.halt()
    here = await ptu.wait_motion()
    assert 0.0 < here.pan < 150.0
    assert not ptu.server.emulator.moving


async def test_mechanical_stop_with_limits_disabled() -> None:
    emu = Ptu46Emulator(time_scale=20)
    emu.limits = False
    async with PtyPtu(emu, baud=0) as unit:
        assert not unit.info.limits_enabled
        here = await unit.move_to(165.0)  # past the 158.9 deg soft limit and the stop
        assert here.pan_pos == 3090 + emu.pan.stop_margin
        await asyncio.sleep(0.05)
        await unit.position()
        assert [axis for _, axis in unit.limit_events] == ["P"]


async def test_move_time_follows_the_model(ptu: PtyPtu) -> None:
    emu = ptu.server.emulator
    predicted = ptu.predict_move_time(pan=-150.0, tilt=25.0)
    start = emu.now()
    await ptu.move_to(-150.0, 25.0)
    elapsed = emu.now() - start
    # Polls every 20 ms real (0.4 s emulated at 20x) bound the overshoot.
    assert predicted <= elapsed + 0.01
    assert elapsed < predicted * 1.1 + 20 * 0.05


async def test_reset_recalibrates(ptu: PtyPtu) -> None:
    ptu.server.emulator.time_scale = 200.0
    await ptu.move_to(40.0, 10.0)
    await ptu.reset()
    here = await ptu.position()
    assert (here.pan_pos, here.tilt_pos) == (0, 0)
    assert not ptu.limit_events  # the calibration's own !T!T!P!P is not an event


async def test_close_halts_a_moving_head() -> None:
    unit = PtyPtu(Ptu46Emulator(time_scale=5), baud=0)
    await unit.open()
    emu = unit.server.emulator
    await unit.move_to(150.0, wait=False)
    await asyncio.sleep(0.05)
    await unit.close()
    assert emu.pan.motion.target < 3000
    assert unit.state is LinkState.DISCONNECTED


async def test_paced_line_like_9600_baud() -> None:
    async with PtyPtu(Ptu46Emulator(time_scale=20)) as unit:  # default: paced at 9600
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        await unit.position()
        # Two replies of at least 3 bytes each ("* 0\r\n") take >= 10 ms at 9600 baud.
        assert loop.time() - t0 >= 0.008


async def test_missing_port() -> None:
    with pytest.raises(PtuConnectionError, match="cannot open"):
        await SerialPtu("/nonexistent/ttyUSB9").open()


async def test_emu_backend_has_the_same_verbs() -> None:
    async with open_ptu("emu://?time_scale=50") as unit:
        assert isinstance(unit, EmulatedPtu)
        here = await unit.move_to(-20.0, 15.0)
        assert (here.pan, here.tilt) == pytest.approx((-20.0, 15.0), abs=0.026)
        with pytest.raises(PtuLimitError):
            await unit.move_to(200.0)
        with pytest.raises(PtuIllegalCommandError):
            await unit._do("QQ")  # type: ignore[attr-defined]
        await unit.reset()
        assert (await unit.position()).pan_pos == 0


def test_urls() -> None:
    assert isinstance(open_ptu("serial:///dev/ttyUSB0?baud=19200"), SerialPtu)
    assert open_ptu("serial:///dev/ttyUSB0?baud=19200").baudrate == 19200  # type: ignore[attr-defined]
    unit = open_ptu("pty://?model=46-70&fault=drop:PP:3&banner=1")
    assert isinstance(unit, PtyPtu)
    assert unit.server.faults[0].nth == 3
    assert unit.server.emulator.model.name == "46-70"
    for bad in ("ftp://x", "emu://?model=nope", "pty://?fault=explode"):
        with pytest.raises(ValueError):
            open_ptu(bad)


async def test_emulator_command_runs_as_a_process(tmp_path: Path) -> None:
    link = tmp_path / "ptu"
    proc = await asyncio.create_subprocess_exec(
        sys.executable,
        "-m",
        "cyborg.daemon",
        "ptu-emulator",
        "--time-scale",
        "20",
        "--link",
        str(link),
        "--tcp",
        "127.0.0.1:0",
        stdout=asyncio.subprocess.PIPE,
        cwd=Path(__file__).resolve().parents[2],
    )
    try:
        assert proc.stdout is not None
        line = await asyncio.wait_for(proc.stdout.readline(), 20)
        assert line.decode().strip() == str(link)
        async with SerialPtu(str(link)) as unit:
            here = await unit.move_to(45.0, -20.0)
            assert here.pan == pytest.approx(45.0, abs=0.026)
        # The same line over TCP, named as the daemon's config names an Ethernet PTU.
        url = (await asyncio.wait_for(proc.stdout.readline(), 20)).decode().strip()
        assert url.startswith("tcp://127.0.0.1:")
        async with open_ptu(url) as unit:
            assert (await unit.position()).pan == pytest.approx(45.0, abs=0.026)
        proc.send_signal(signal.SIGTERM)
        assert await asyncio.wait_for(proc.wait(), 10) == 0
        assert not link.exists()
    finally:
        if proc.returncode is None:
            proc.kill()
            await proc.wait()
    assert os.path.exists("/dev/ptmx")


async def test_only_an_axis_still_on_its_way_is_polled() -> None:
    """An axis seen on its target has stopped there (a trapezoid never overshoots), so a
    pan-only move asks the tilt once, and the stop is seen in half the line's time."""
    async with PtyPtu(Ptu46Emulator(), baud=0) as unit:  # real time: a 10° move, ~0.25 s
        executed = unit.server.emulator.executed
        before = executed.copy()
        here = await unit.move_to(pan=10.0)
        assert here.pan == pytest.approx(10.0, abs=0.026) and not here.moving
        asked = executed - before
        assert asked["PP"] >= 3  # the command, then polls until the stop is seen
        assert asked["TP"] == 1
