"""A simulated camera invents no pixels: a survey whose mosaic reaches past the panorama is
refused with both ranges before anything moves, a mosaic inside is shot from the panorama
alone, and a frame that still looks past the edge shows NO_DATA there, not a smear."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from cyborg.daemon.camera import SimulatedCamera, open_camera
from cyborg.daemon.camera.simulated import NO_DATA
from cyborg.daemon.pointing.geometry import CameraModel, MosaicGeometry, pixel_to_angles
from cyborg.protocol.messages import SurveyStart
from tests.survey.test_survey_engine import _engine


def _panorama(folder: Path, rng: np.random.Generator) -> Path:
    """A user's own panorama, 120 x 40 deg at 8 px/deg: texture in every row (no two rows
    alike, none black), as a file."""
    image = rng.integers(40, 220, (320, 960, 3), dtype=np.uint8)
    path = folder / "huge.png"
    assert cv2.imwrite(str(path), image)
    return path


async def test_a_mosaic_past_the_panorama_is_refused_before_anything_moves(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    url = f"sim://{_panorama(tmp_path, rng)}?pan=-60,60&tilt=-20,20"
    async with _engine(tmp_path, camera=url) as (survey, _, archive):
        with pytest.raises(ValueError) as refused:
            survey.start(SurveyStart(), "tester")  # the configured 2x3 reaches +-24.2 deg
        assert str(refused.value) == (
            "the 2×3 mosaic at pan 0.0, tilt 0.0 reaches tilt -24.2° and tilt 24.2°; "
            "the camera's scene shows pan -60..60°, tilt -20..20°"
        )
        here = await survey.rig.ptu.position()
        assert (here.pan, here.tilt) == (0.0, 0.0) and survey.station is None
        assert archive.sessions() == []

        survey.start(SurveyStart(rows=1, cols=3), "tester")  # pan +-46, tilt +-12.1: inside
        await survey._task
        station = survey.station
        assert station.manifest["status"] == "complete"
        mosaic = cv2.imread(str(station.folder / "mosaic.png"), cv2.IMREAD_COLOR)
        assert not (mosaic == NO_DATA).all(axis=2).any()


def test_a_frame_past_the_edge_shows_no_data_not_smear(
    tmp_path: Path, rng: np.random.Generator
) -> None:
    cam = open_camera(f"sim://{_panorama(tmp_path, rng)}?pan=-60,60&tilt=-20,20&noise=3")
    assert isinstance(cam, SimulatedCamera) and cam.extent == ((-60.0, 60.0), (-20.0, 20.0))
    pan, tilt = 10.0, -12.0  # the frame's bottom reaches -24.1 deg: below the panorama
    image = cam._expose(pan, tilt)
    w, h = cam.resolution
    xs, ys = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    beyond = pixel_to_angles(xs, ys, pan, tilt, cam.model)[1] < -20.0
    assert beyond[-1].all() and not beyond[0].any()
    assert (image[beyond] == NO_DATA).all()  # exactly, without sensor noise
    assert not (image[~beyond] == NO_DATA).all(axis=1).any()
    # What the frame shows is the panorama: no row repeats the one above (a smear would).
    clean = cam.render(pan, tilt).astype(int)
    rows = [r for r in range(1, h) if not beyond[r].any()]
    assert all(np.abs(clean[r] - clean[r - 1]).mean() > 5 for r in rows)


def test_a_camera_without_edges_takes_any_plan() -> None:
    """The world (and every real camera) states no extent: no plan is refused for it."""
    assert open_camera("sim://world?seed=1").extent is None
    wide = MosaicGeometry(CameraModel(), 4, 8, tilt0=30.0)
    assert wide.extent[1][1] > 60.0
    wide.check_within(None)
