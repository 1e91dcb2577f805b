"""The simulated camera draws the world where the geometry says it is."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from cyborg.daemon.camera import CameraError, Panorama, SimulatedCamera, open_camera
from cyborg.daemon.pointing.geometry import CameraModel, angles_to_pixel
from cyborg.daemon.ptu import open_ptu


def _dot_panorama(pan: float, tilt: float) -> Panorama:
    """A dark sky with one bright dot at (pan, tilt), 20 px per degree."""
    image = np.zeros((800, 1600, 3), np.uint8)
    pano = Panorama(image, (-40.0, 40.0), (-20.0, 20.0))
    x, y = pano.to_pixel(pan, tilt)
    # cv2 draws in pixel-index coordinates: the continuous point x sits at index x - 0.5.
    centre = (round((float(x) - 0.5) * 16), round((float(y) - 0.5) * 16))
    cv2.circle(image, centre, 16 * 4, (255, 255, 255), -1, cv2.LINE_AA, shift=4)
    return pano


def _centroid(image: np.ndarray) -> tuple[float, float]:
    grey = image[..., 0].astype(np.float64)
    ys, xs = np.indices(grey.shape)
    return float((xs * grey).sum() / grey.sum()), float((ys * grey).sum() / grey.sum())


@pytest.mark.parametrize("pose", [(0.0, 0.0), (3.0, 2.0), (10.0, -6.0), (-5.0, 4.0)])
async def test_dot_lands_on_the_predicted_pixel(pose: tuple[float, float]) -> None:
    cam = SimulatedCamera(_dot_panorama(7.0, -1.0), CameraModel(720, 576, 30.0), noise=0)
    cam.fixed_pose = pose
    frame = await cam.grab()
    assert frame.image.shape == (576, 720, 3) and frame.pose == pose
    x, y = angles_to_pixel(7.0, -1.0, *pose, cam.model)
    cx, cy = _centroid(frame.image)
    # Continuous coordinates: the centroid of pixel indices sits half a pixel lower.
    assert (cx + 0.5, cy + 0.5) == pytest.approx((float(x), float(y)), abs=0.5)


async def test_zoom_narrows_the_view() -> None:
    cam = SimulatedCamera(_dot_panorama(4.0, 0.0), noise=0)
    wide = _centroid((await cam.grab()).image)[0] - 360
    await cam.zoom(2.0)
    tele = _centroid((await cam.grab()).image)[0] - 360
    assert tele == pytest.approx(2 * wide, rel=0.02)
    with pytest.raises(ValueError):
        await cam.zoom(0.5)


async def test_outcrop_target_follows_the_ptu() -> None:
    cam = SimulatedCamera.from_url("sim://outcrop?seed=5&noise=0")  # a cliff with a plant
    plant = next(t for t in cam.panorama.targets if t.kind == "plant")
    async with open_ptu("emu://?time_scale=50") as ptu:

        async def pose() -> tuple[float, float]:
            here = await ptu.position()
            return here.pan, here.tilt

        cam.pose_source = pose
        await ptu.move_to(plant.pan - 4.0, plant.tilt + 2.0)
        frame = await cam.grab()
        x, y = angles_to_pixel(plant.pan, plant.tilt, *frame.pose, cam.model)
        b, g, r = (frame.image[..., i].astype(int) for i in range(3))
        green = (g > r + 30) & (g > b + 30)
        ys, xs = np.nonzero(green)
        assert len(xs) > 100
        radius_px = plant.radius * cam.model.focal * np.pi / 180
        assert np.hypot(xs.mean() + 0.5 - float(x), ys.mean() + 0.5 - float(y)) < radius_px / 3
        # The pose is the PTU's, quantised to its steps: not the commanded angles.
        assert frame.pose != (plant.pan - 4.0, plant.tilt + 2.0)
        assert frame.pose == pytest.approx((plant.pan - 4.0, plant.tilt + 2.0), abs=0.026)


async def test_noise_is_seeded_and_present() -> None:
    a = SimulatedCamera.from_url("sim://outcrop?seed=3&noise=3")
    b = SimulatedCamera.from_url("sim://outcrop?seed=3&noise=3")
    fa, fb = await a.grab(), await b.grab()
    assert np.array_equal(fa.image, fb.image)
    clean = a.render(0.0, 0.0)
    diff = fa.image.astype(int) - clean
    assert 2.0 < diff.std() < 4.0


def test_urls_and_errors(tmp_path) -> None:
    pano = tmp_path / "pano.png"
    cv2.imwrite(str(pano), np.full((100, 400), 128, np.uint8))
    cam = open_camera(f"sim://{pano}?pan=-20,20&tilt=-5,5&width=320&height=240&hfov=10")
    assert isinstance(cam, SimulatedCamera)
    assert cam.resolution == (320, 240)
    assert cam.panorama.image.shape == (100, 400, 3)
    with pytest.raises(CameraError, match="no such file"):
        open_camera(f"sim://{tmp_path / 'missing.png'}")
    with pytest.raises(ValueError):
        open_camera("sim://")
    with pytest.raises(ValueError):
        open_camera(f"sim://{pano}?pan=5,-5")
