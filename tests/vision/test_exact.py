"""The same image gives the same analysis, bit for bit, on every run (``vision.exact``)."""

from __future__ import annotations

import cv2
import numpy as np

from cyborg.daemon.sim.scene import outcrop_scene
from cyborg.daemon.vision.job import analyze_image
from cyborg.daemon.vision.params import PROFILES


def _maps(profile: str, image: np.ndarray) -> list[np.ndarray]:
    res = analyze_image(image, PROFILES[profile])[1]
    m = res.interest
    return [a for a in (m.grid, m.blurred, m.plain, m.lines) if a is not None]


def test_repeated_analyses_of_one_image_are_identical() -> None:
    # A mosaic with a black no-data fill: IPP's cv2.magnitude in the roundness gave a map 1 ulp
    # off on about one run in two, as the arrays it was handed lay in memory.
    image = outcrop_scene(3, (288, 540)).image.copy()
    image[:, :80] = 0
    image[:40, :] = 0
    first = _maps("uncommon", image)
    for _ in range(8):
        again = _maps("uncommon", image)
        assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))


def test_the_callers_opencv_is_left_as_it_was() -> None:
    image = outcrop_scene(1, (96, 128)).image
    was = cv2.ipp.useIPP()
    try:
        for setting in (True, False):
            cv2.ipp.setUseIPP(setting)
            analyze_image(image, PROFILES["default"])
            assert cv2.ipp.useIPP() is setting
    finally:
        cv2.ipp.setUseIPP(was)
