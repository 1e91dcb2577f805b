"""A real head's errors in the emulator: it reports its step count while it truly looks a
few tenths of a degree off (repeatably, by place) and lags by its backlash after a reversal;
off by default, where the report is the truth."""

from __future__ import annotations

import numpy as np
import pytest

from cyborg.daemon.camera.simulated import SimulatedCamera
from cyborg.daemon.ptu import PtyPtu, open_ptu
from cyborg.daemon.ptu.emulated import EmulatedPtu
from cyborg.daemon.rig import Rig
from cyborg.daemon.sim.world import World

pytestmark = pytest.mark.timeout(60)

STEP = 185.1428 / 3600.0
"""One D46-17 pan or tilt position, degrees."""


async def _look(ptu: EmulatedPtu | PtyPtu, pan: float, tilt: float) -> tuple[float, float]:
    """Move, then where the head reports and where it truly looks, as (dpan, dtilt)."""
    reported = await ptu.move_to(pan, tilt)
    pose = ptu.true_pose
    assert pose is not None
    true = await pose()
    return true[0] - reported.pan, true[1] - reported.tilt


async def test_without_errors_the_report_is_the_truth() -> None:
    ptu = open_ptu("emu://?time_scale=100")
    assert isinstance(ptu, EmulatedPtu) and ptu.true_pose is None
    await ptu.open()
    try:
        reported = await ptu.move_to(12.0, -4.0)
        assert ptu.emulator.pointing() == pytest.approx((reported.pan, reported.tilt))
        # the camera of a rig without errors renders from the reported pose, as before
        rig = Rig(ptu, lambda pose: SimulatedCamera(World(0), pose=pose))
        rig.note(reported)
        assert (await rig.grab()).pose == (reported.pan, reported.tilt)
    finally:
        await ptu.close()


async def test_a_rig_with_errors_renders_the_truth_and_labels_the_report() -> None:
    """The camera sees from where the head truly looks; the frame (what the live view's
    header and the survey get) says where the head reported, as a real rig knows only that."""
    ptu = open_ptu("emu://?time_scale=100&pointing_error=0.3&backlash=0.1&error_seed=3")
    assert isinstance(ptu, EmulatedPtu)
    rig = Rig(ptu, lambda pose: SimulatedCamera(World(0), pose=pose, noise=0.0))
    await ptu.open()
    try:
        rig.note(await ptu.position())
        reported = await rig.move_to(12.0, -4.0)
        true = ptu.emulator.pointing()
        assert (
            max(abs(t - r) for t, r in zip(true, (reported.pan, reported.tilt), strict=True)) > STEP
        )
        frame = await rig.grab()
        assert frame.pose == (reported.pan, reported.tilt)
        camera = rig.camera
        assert isinstance(camera, SimulatedCamera)
        assert np.array_equal(frame.image, camera.render(*true))
    finally:
        await ptu.close()


async def test_pointing_error_is_seeded_and_repeatable_by_place() -> None:
    url = "emu://?time_scale=100&pointing_error=0.3&error_seed=5"
    a, b = open_ptu(url), open_ptu(url)
    other = open_ptu(url.replace("seed=5", "seed=6"))
    for unit in (a, b, other):
        await unit.open()
    try:
        here = await _look(a, 20.0, 5.0)
        assert max(abs(v) for v in here) > STEP  # off by more than a step
        assert await _look(b, 20.0, 5.0) == here  # the same seed, the same head
        assert await _look(other, 20.0, 5.0) != here
        await _look(a, -30.0, 10.0)
        assert await _look(a, 20.0, 5.0) == pytest.approx(here)  # the same place again
        near = await _look(a, 20.3, 5.3)  # a correction away: nearly the same error
        assert all(abs(n - h) < STEP for n, h in zip(near, here, strict=True))
    finally:
        for unit in (a, b, other):
            await unit.close()


async def test_backlash_lags_after_a_reversal_on_the_real_driver() -> None:
    """Through the serial driver on a pty: arriving at one place from either side, the
    head looks one dead band apart on each axis."""
    ptu = PtyPtu.from_url("pty://?time_scale=50&baud=0&backlash=0.2,0.1")
    await ptu.open()
    try:
        await ptu.move_to(0.0, 0.0)
        from_below = await _look(ptu, 10.0, 5.0)
        await ptu.move_to(15.0, 8.0)
        from_above = await _look(ptu, 10.0, 5.0)
        assert from_above[0] - from_below[0] == pytest.approx(0.2, abs=1e-6)
        assert from_above[1] - from_below[1] == pytest.approx(0.1, abs=1e-6)
        assert await _look(ptu, 12.0, 6.0) == pytest.approx(from_below)  # onwards: taken up
    finally:
        await ptu.close()


def test_bad_errors_are_refused() -> None:
    with pytest.raises(ValueError, match="backlash"):
        open_ptu("emu://?backlash=0.1,0.2,0.3")
    with pytest.raises(ValueError, match=">= 0 degrees"):
        open_ptu("emu://?pointing_error=-1")
