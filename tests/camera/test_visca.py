"""The VISCA zoom driver against the emulator of its subset on a real pty."""

from __future__ import annotations

import os

import pytest

from cyborg.daemon.camera.visca import ViscaEmulator, ViscaError, ViscaZoom


@pytest.fixture
async def lens():
    emulator = await ViscaEmulator(full_travel=0.4).start()
    zoom = ViscaZoom(emulator.path, max_level=30.0, timeout=3.0)
    await zoom.open()
    yield zoom, emulator
    await zoom.close()
    await emulator.close()


async def test_zoom_goes_where_asked_and_says_how_long_it_took(lens) -> None:
    zoom, emulator = lens
    assert await zoom.level() == pytest.approx(1.0)
    took = await zoom.set_level(5.0)
    assert took > 0 and emulator.position == zoom.position_of(5.0)
    assert await zoom.level() == pytest.approx(5.0, rel=1e-3)
    await zoom.set_level(30.0)
    assert emulator.position == 0x4000 and await zoom.level() == pytest.approx(30.0)
    await zoom.set_level(0.5)  # clipped to the lens's range
    assert emulator.position == 0 and await zoom.level() == pytest.approx(1.0)


async def test_refusals_and_noise_on_the_line(lens) -> None:
    zoom, emulator = lens
    await zoom.set_level(3.0)
    os.write(emulator._master, b"\x00\x13garbage\xff")  # noise on the line is skipped
    assert await zoom.level() == pytest.approx(3.0, rel=1e-3)
    with pytest.raises(ViscaError, match="syntax error"):
        await zoom._exchange(bytes.fromhex("8101FF"), final=lambda p: False)
    assert await zoom.level() == pytest.approx(3.0, rel=1e-3)  # and it still answers


async def test_a_missing_port_and_a_closed_one_say_so() -> None:
    with pytest.raises(ViscaError, match="cannot open /dev/nope"):
        await ViscaZoom("/dev/nope").open()
    with pytest.raises(ViscaError, match="not open"):
        await ViscaZoom("/dev/nope").level()
