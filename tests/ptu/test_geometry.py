"""Pixels, angles and mosaics: the mapping used to re-point at interest points."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from cyborg.daemon.camera import SimulatedCamera
from cyborg.daemon.pointing.geometry import (
    CameraModel,
    MosaicGeometry,
    angles_to_pixel,
    degrees_to_positions,
    pixel_to_angles,
    positions_to_degrees,
)

CAM = CameraModel(720, 576, 30.0)


def test_positions_and_degrees() -> None:
    for res in (185.1428, 46.2857, 92.5714):
        for pos in (-3090, -1, 0, 1, 604, 12360):
            assert degrees_to_positions(positions_to_degrees(pos, res), res) == pos


@pytest.mark.parametrize("pose", [(0.0, 0.0), (40.0, 25.0), (-150.0, -45.0)])
def test_pixel_angle_round_trip(pose: tuple[float, float], rng: np.random.Generator) -> None:
    x, y = rng.uniform(0, 720, 200), rng.uniform(0, 576, 200)
    a, b = pixel_to_angles(x, y, *pose, CAM)
    x2, y2 = angles_to_pixel(a, b, *pose, CAM)
    np.testing.assert_allclose(x2, x, atol=1e-6)
    np.testing.assert_allclose(y2, y, atol=1e-6)


def test_image_edges_and_behind() -> None:
    a, b = pixel_to_angles(np.array([0.0, 720.0]), np.array([288.0, 288.0]), 0.0, 0.0, CAM)
    np.testing.assert_allclose(b, [0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(a, [-15.0, 15.0])
    assert CAM.vfov == pytest.approx(24.1976, abs=1e-3)
    x, _ = angles_to_pixel(180.0, 0.0, 0.0, 0.0, CAM)
    assert np.isnan(x)
    # Away from the horizon a pixel's pan is not the camera pan plus a fixed offset.
    top_left = pixel_to_angles(0.0, 0.0, 0.0, 30.0, CAM)[0]
    assert float(top_left) < -16.0


def test_mosaic_tiles_and_round_trip() -> None:
    g = MosaicGeometry(CAM, 3, 4, pan0=10.0, tilt0=-5.0, downsample=4)
    assert g.tile_size == (180, 144) and g.size == (720, 432)
    assert len(g.serpentine()) == 12 and g.serpentine()[4] == (1, 3)
    for row, col in g.serpentine():
        pan, tilt = g.tile_pose(row, col)
        cx, cy = (col + 0.5) * 180, (row + 0.5) * 144
        assert g.to_angles(cx, cy) == pytest.approx((pan, tilt), abs=1e-9)
    for mx, my in [(5.5, 3.25), (400.0, 200.0), (719.0, 431.0)]:
        back = g.to_mosaic(*g.to_angles(mx, my))
        assert back == pytest.approx((mx, my), abs=1e-6)
    assert g.to_mosaic(170.0, 0.0) is None


def test_a_direction_on_a_seam_is_seen() -> None:
    """The centre of a two-row mosaic lies on the seam between its rows; floating point puts
    it a hair outside both tiles (this zoomed station's aim once did), and the next station's
    memory lost the chosen target."""
    zoomed = CameraModel(720, 576, 1.0234633086100724)
    for camera, pan0, tilt0 in [(zoomed, -4.6276, 1.5409), (CAM, 3.0, -7.25), (CAM, 0.0, 0.0)]:
        g = MosaicGeometry(camera, 2, 3, pan0=pan0, tilt0=tilt0, downsample=4)
        assert g.to_mosaic(pan0, tilt0) == pytest.approx((270.0, 144.0), abs=1e-6)


async def test_planted_target_is_where_the_mosaic_says() -> None:
    """Shoot a butted 2x3 mosaic with the simulated camera; find the plant through geometry."""
    cam = SimulatedCamera.from_url("sim://outcrop?seed=5&noise=0")  # a cliff with a plant
    plant = next(t for t in cam.panorama.targets if t.kind == "plant")
    g = MosaicGeometry(cam.model, 2, 3, pan0=plant.pan - 7.0, tilt0=plant.tilt + 3.0, downsample=4)
    w, h = g.tile_size
    mosaic = np.zeros((g.size[1], g.size[0], 3), np.uint8)
    for row, col in g.serpentine():
        cam.fixed_pose = g.tile_pose(row, col)
        tile = cv2.resize((await cam.grab()).image, (w, h), interpolation=cv2.INTER_AREA)
        mosaic[row * h : (row + 1) * h, col * w : (col + 1) * w] = tile
    where = g.to_mosaic(plant.pan, plant.tilt)
    assert where is not None
    b, gr, r = (mosaic[..., i].astype(int) for i in range(3))
    ys, xs = np.nonzero((gr > r + 30) & (gr > b + 30))
    assert np.hypot(xs.mean() + 0.5 - where[0], ys.mean() + 0.5 - where[1]) < 2.0
    # ...and from the mosaic pixel back to where the PTU must point.
    pan, tilt = g.to_angles(xs.mean() + 0.5, ys.mean() + 0.5)
    assert (pan, tilt) == pytest.approx((plant.pan, plant.tilt), abs=0.15)
