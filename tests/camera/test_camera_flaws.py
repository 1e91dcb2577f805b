"""A real camera's flaws in the simulated one: vignetting, radial distortion OpenCV can
undo, and an auto-exposure that follows the scene with a lag and drifts; all off unless a
URL asks, seeded."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from cyborg.daemon.camera.simulated import (
    AE_TARGET,
    PAN,
    TILT,
    Imperfections,
    Panorama,
    SimulatedCamera,
)
from cyborg.daemon.pointing.geometry import CameraModel
from cyborg.daemon.sim.world import World

pytestmark = pytest.mark.timeout(120)

SMALL = CameraModel(240, 192, 30.0)


def _camera(flaws: Imperfections, pose: tuple[float, float] = (0.0, 0.0)) -> SimulatedCamera:
    cam = SimulatedCamera(World(4), SMALL, noise=0.0, seed=1, imperfections=flaws)
    cam.fixed_pose = pose
    return cam


async def _shot(flaws: Imperfections, pose: tuple[float, float]) -> np.ndarray:
    return (await _camera(flaws, pose).grab()).image


def test_off_unless_a_url_asks() -> None:
    plain = SimulatedCamera.from_url("sim://world?seed=2")
    assert not plain.imperfections.enabled
    asked = SimulatedCamera.from_url("sim://world?seed=2&vignetting=0.3&k1=-0.1&ae_walk=0.02")
    assert asked.imperfections == Imperfections(vignetting=0.3, k1=-0.1, ae_walk=0.02)
    with pytest.raises(ValueError, match="vignetting"):
        SimulatedCamera.from_url("sim://world?vignetting=1.5")


async def test_vignetting_darkens_the_corners_only() -> None:
    ideal = (await _shot(Imperfections(), (10.0, 0.0))).astype(float)
    dark = (await _shot(Imperfections(vignetting=0.3), (10.0, 0.0))).astype(float)
    assert np.abs(dark[90:102, 114:126] - ideal[90:102, 114:126]).mean() < 1.0
    corner = dark[:12, :12].mean() / ideal[:12, :12].mean()
    assert 0.65 < corner < 0.8


async def test_distortion_is_what_opencv_undoes() -> None:
    """The distorted frame, undistorted by OpenCV with the same k1, k2, is the ideal one."""
    k1, k2 = -0.25, 0.05
    ideal = await _shot(Imperfections(), (-20.0, 5.0))
    bent = await _shot(Imperfections(k1=k1, k2=k2), (-20.0, 5.0))
    f = SMALL.focal
    matrix = np.array([[f, 0, SMALL.width / 2 - 0.5], [0, f, SMALL.height / 2 - 0.5], [0, 0, 1]])
    straight = cv2.undistort(bent, matrix, np.array([k1, k2, 0.0, 0.0]))
    inner = (slice(20, -20), slice(20, -20))

    def differs(a: np.ndarray) -> float:
        return float(np.abs(a[inner].astype(float) - ideal[inner].astype(float)).mean())

    assert differs(straight) < differs(bent) / 3


async def test_auto_exposure_follows_the_scene_with_a_lag_and_drifts() -> None:
    flaws = Imperfections(ae_lag=0.5, ae_walk=0.05)
    cam = _camera(flaws)
    first = await cam.grab()
    assert first.exposure.auto and abs(first.image.mean() - AE_TARGET) < 10
    gains = [(await cam.grab()).exposure.gain_db for _ in range(4)]
    assert len(set(gains)) == 4  # drifts on a still scene
    again = _camera(flaws)
    assert [(await again.grab()).exposure.gain_db for _ in range(5)] == [
        first.exposure.gain_db,
        *gains,
    ]  # seeded


async def test_auto_exposure_catches_up_with_a_darker_scene_frame_by_frame() -> None:
    bright = np.full((520, 1000, 3), 120, np.uint8)
    cam = SimulatedCamera(Panorama(bright, PAN, TILT), SMALL, noise=0.0)
    cam.imperfections = Imperfections(ae_lag=0.5)
    settled = (await cam.grab()).exposure.gain_db
    cam.panorama = Panorama(bright // 3, PAN, TILT)
    steps = [(await cam.grab()).exposure.gain_db for _ in range(6)]
    assert settled < steps[0] < steps[1] < steps[-1]
    assert steps[-1] - steps[-2] < steps[1] - steps[0]
    means = [(await cam.grab()).image.mean() for _ in range(8)]
    assert abs(means[-1] - AE_TARGET) < abs(means[0] - AE_TARGET) + 1
