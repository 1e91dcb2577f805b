"""Refined pointing for chips, on the emulated head with a real head's errors (0.3 deg
pointing error and backlash, seeded) under the simulated camera with a real camera's flaws:
a chip off its target by more than a step is corrected once and retaken, and lands within a
step; a head without errors is left alone, its chips as they were; a butted mosaic's
neighbouring tile, off by its own error, does not pull the measurement."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from bench.chips import station_chips
from cyborg.daemon.camera.simulated import Imperfections, SimulatedCamera
from cyborg.daemon.pointing.geometry import CameraModel, MosaicGeometry
from cyborg.daemon.sim.world import World
from cyborg.daemon.survey.refine import CORRECTION_THRESHOLD, measure
from cyborg.protocol.messages import SurveyStart
from tests.survey.test_survey_engine import _engine

pytestmark = pytest.mark.timeout(180)


async def test_refined_chips_land_within_a_step_where_plain_ones_do_not() -> None:
    plain, refined = await station_chips(1)
    assert [c.chip.rank for c in refined] == [c.chip.rank for c in plain] == [1, 2, 3]
    assert all(c.error_deg > CORRECTION_THRESHOLD for c in plain)
    assert all(c.error_deg <= CORRECTION_THRESHOLD for c in refined)
    for c in refined:  # the manifest says how far off the chip was, and that it was corrected
        record = c.centring
        assert record["corrected"] is True
        assert record["before_deg"] > CORRECTION_THRESHOLD >= record["after_deg"]
        assert 0.0 < record["confidence"] <= 1.0
        assert 0.0 <= record["uncertainty_deg"] < record["before_deg"]


async def test_a_head_without_errors_is_left_alone() -> None:
    plain, refined = await station_chips(1, head_errors="", flaws=Imperfections())
    assert [(c.chip.pan, c.chip.tilt) for c in refined] == [
        (c.chip.pan, c.chip.tilt) for c in plain
    ]
    assert all(c.centring["corrected"] is False for c in refined)
    assert all(c.centring["before_deg"] <= CORRECTION_THRESHOLD for c in refined)


async def test_a_survey_records_every_chips_centring(tmp_path: Path) -> None:
    """Through the survey engine (a real worker) on a head without errors: each chip's
    centring is in the station's manifest, measured within a step and not corrected."""
    async with _engine(tmp_path) as (survey, rec, _):
        survey.start(SurveyStart(rows=1, cols=2), "tester")
        await survey._task
        chips = survey.station.manifest["chips"]
        assert len(chips) == len(rec.chips) > 0
        for chip in chips:
            assert chip["centring"]["corrected"] is False
            assert chip["centring"]["before_deg"] <= CORRECTION_THRESHOLD


def test_a_textureless_view_is_not_measured_as_an_offset() -> None:
    geometry = MosaicGeometry(CameraModel(), 2, 3, downsample=4.0)
    width, height = geometry.size
    mosaic = np.full((height, width, 3), 90, np.uint8)
    chip = np.full((576, 720, 3), 90, np.uint8)
    found = measure(chip, (1.0, 2.0), (1.0, 2.0), mosaic, geometry)
    assert found is None or not found.needs_correction


async def test_a_butted_neighbour_off_by_its_own_error_does_not_pull_the_measurement() -> None:
    """Two butted tiles, the right one shot 0.4 deg off what its slot says; a chip aimed a
    degree and a half left of the seam registers on its own tile only."""
    geometry = MosaicGeometry(CameraModel(), 1, 2, downsample=4.0)
    camera = SimulatedCamera(World(2), geometry.camera, noise=0.0)
    tiles = []
    for col, error in ((0, (0.0, 0.0)), (1, (0.4, -0.3))):
        pan, tilt = geometry.tile_pose(0, col)
        camera.fixed_pose = (pan + error[0], tilt + error[1])
        frame = (await camera.grab()).image
        tiles.append(cv2.resize(frame, geometry.tile_size, interpolation=cv2.INTER_AREA))
    mosaic = np.hstack(tiles)
    target = (-1.5, 2.0)  # the seam is at pan 0
    camera.fixed_pose = (target[0] + 0.2, target[1] - 0.15)  # where the head truly looks
    found = measure((await camera.grab()).image, target, target, mosaic, geometry)
    assert found is not None and found.trusted
    assert found.offset == pytest.approx((-0.2, 0.15), abs=0.01)


async def test_chips_on_a_registered_mosaic_are_aimed_through_their_tiles() -> None:
    """A point's angles are in the mosaic's frame, the first tile's; the head is sent there
    less the registration's correction of the tile that shows it, as that tile's pose was
    off (a head's error is repeatable), and the chip's record says by how much."""
    plain, refined = await station_chips(0, overlap=0.3)
    step = 185.1428 / 3600.0
    shifts = [c.centring["tile_correction_deg"] for c in refined]
    assert max(float(np.hypot(*s)) for s in shifts) > 2 * step  # tiles were off the first
    for chip, shift in zip(plain, shifts, strict=True):
        goal = (chip.point.pan - shift[0], chip.point.tilt - shift[1])
        assert abs(chip.chip.pan - goal[0]) <= step / 2 + 1e-6
        assert abs(chip.chip.tilt - goal[1]) <= step / 2 + 1e-6
