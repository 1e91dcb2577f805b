"""The trapezoid model and the emulator's integration of it agree."""

from __future__ import annotations

import pytest

from cyborg.daemon.ptu.motion import Axis, move_time


def _run(axis: Axis, step: float = 0.001, limit: float = 30.0) -> float:
    t = 0.0
    while axis.moving and t < limit:
        axis.advance(step)
        t += step
    return t


@pytest.mark.parametrize("distance", [1, 37, 500, 1000, 3705, 6180, -2500])
@pytest.mark.parametrize(("speed", "base"), [(1000, 1000), (2900, 1000), (500, 1000), (2000, 57)])
def test_integration_matches_formula(distance: int, speed: float, base: float) -> None:
    axis = Axis(target=distance, speed=speed, base=base, accel=2000)
    t = _run(axis)
    assert axis.position == distance and axis.velocity == 0
    assert t == pytest.approx(move_time(distance, speed, base, 2000), abs=0.0021)


def test_triangle_profile_peak() -> None:
    # 1000 positions at PS2900: the ramp would need 3705, so the profile is a triangle.
    assert move_time(1000, 2900, 1000, 2000) == pytest.approx(2 * (1732.0508 - 1000) / 2000)


def test_large_steps_equal_small_steps() -> None:
    a, b = Axis(target=4000, speed=2500), Axis(target=4000, speed=2500)
    a.advance(1.3)
    for _ in range(1300):
        b.advance(0.001)
    assert a.position == pytest.approx(b.position, abs=1e-6)
    assert a.velocity == pytest.approx(b.velocity, abs=1e-6)


def test_retarget_behind_reverses_and_arrives() -> None:
    axis = Axis(target=3000, speed=2000)
    axis.advance(0.5)
    assert (axis.position, axis.velocity) == (750, 2000)
    axis.target = -500
    _run(axis)
    assert axis.position == -500 and not axis.moving


def test_halt_ramps_down() -> None:
    axis = Axis(target=3000, speed=2000)
    axis.advance(0.5)
    axis.halt()
    assert axis.target == 1500  # 750 + (2000² - 1000²) / (2 · 2000)
    assert _run(axis) == pytest.approx(0.5, abs=0.002)


def test_speed_lowered_mid_move() -> None:
    axis = Axis(target=6000, speed=2500)
    axis.advance(1.0)
    axis.speed = 1200
    _run(axis)
    assert axis.position == 6000


def test_bad_speed() -> None:
    with pytest.raises(ValueError):
        move_time(10, 0, 1000, 2000)
