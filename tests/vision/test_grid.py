"""Blurs and reductions on grids of block means stand in for the exact operations."""

import cv2
import numpy as np
import pytest

from cyborg.daemon.sim.scene import outcrop_scene
from cyborg.daemon.vision.grid import expand, reduce_to, surround


@pytest.fixture(scope="module")
def outcrop() -> np.ndarray:
    return cv2.resize(outcrop_scene(4).image, (1200, 900), interpolation=cv2.INTER_CUBIC)


@pytest.mark.parametrize("size", [(374, 288), (431, 331), (200, 150)])
def test_reduction_keeps_a_target_where_it_is(size):
    """The centre of a spot, read in the reduced image and mapped back with the pipeline's
    pixel-centre convention, is where it was drawn (to a pixel of the input)."""
    plane = np.zeros((1000, 1300), np.uint8)
    cv2.circle(plane, (777, 333), 40, 255, -1)
    small = reduce_to(plane, size).astype(np.float64)
    ys, xs = np.mgrid[: small.shape[0], : small.shape[1]]
    cx, cy = (xs * small).sum() / small.sum(), (ys * small).sum() / small.sum()
    assert small.shape == size[::-1]
    assert abs((cx + 0.5) * 1300 / size[0] - 0.5 - 777) < 1.0
    assert abs((cy + 0.5) * 1000 / size[1] - 0.5 - 333) < 1.0


def test_reduction_is_an_area_average(outcrop):
    exact = cv2.resize(outcrop, (374, 281), interpolation=cv2.INTER_AREA).astype(np.float32)
    fast = reduce_to(outcrop, (374, 281)).astype(np.float32)
    assert float(np.abs(fast - exact).mean()) < 2.0  # grey levels of 255
    # Whole blocks, and reductions under 2x, are OpenCV's area average itself.
    for size in ((400, 300), (1000, 750)):
        assert np.array_equal(
            reduce_to(outcrop, size), cv2.resize(outcrop, size, interpolation=cv2.INTER_AREA)
        )


@pytest.mark.parametrize("sigma", [4.0, 6.0, 16.0])
def test_surround_matches_the_exact_blur(outcrop, sigma):
    plane = cv2.log(cv2.cvtColor(outcrop, cv2.COLOR_BGR2GRAY).astype(np.float32) + 8.0)
    grid, f = surround(plane, sigma)
    exact = cv2.GaussianBlur(plane, (0, 0), sigma)
    assert f == 2
    error = np.abs(expand(grid, f, plane.shape) - exact)
    assert float(error.max()) < 0.01 * float(np.ptp(plane))
