"""Seams cut again off the points the science found: a point on a seam ends up inside one
frame, a point no seam is near leaves the seams as they were, and the re-cut mosaic is still
black exactly where no frame covers."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from cyborg.daemon.camera.simulated import SimulatedCamera
from cyborg.daemon.pointing.geometry import SphericalMosaic
from cyborg.daemon.survey.stitch import KEEP_OFF_PX, Stitcher, uncovered
from tests.survey.test_stitch import CAM, _errors, _stitch
from tests.survey.test_stitched_nodata import _corner_missed


async def _registered() -> tuple[Stitcher, np.ndarray]:
    """A 2x3 registered mosaic of the simulated cliff from a head 0.3° off per axis."""
    camera = SimulatedCamera.from_url("sim://outcrop?seed=5&noise=2")
    g = SphericalMosaic(CAM, 2, 3, 10.0, 2.0, 4.0, overlap=0.3)
    return await _stitch(camera, g, _errors(6, 1))


def _seam_points(owners: np.ndarray) -> list[tuple[float, float]]:
    """One point on the middle of each seam between a pair of tiles: the pixel where the
    owner changes nearest that seam's centroid."""
    left, right = owners[:, :-1], owners[:, 1:]
    up, down = owners[:-1], owners[1:]
    seams: dict[tuple[int, int], list[tuple[int, int]]] = {}
    for a, b, (ys, xs) in (
        (left, right, np.nonzero((left != right) & (left >= 0) & (right >= 0))),
        (up, down, np.nonzero((up != down) & (up >= 0) & (down >= 0))),
    ):
        for y, x in zip(ys, xs, strict=True):
            pair = tuple(sorted((int(a[y, x]), int(b[y, x]))))
            seams.setdefault(pair, []).append((x, y))
    points = []
    for pixels in seams.values():
        at = np.array(pixels, float)
        points.append(tuple(at[np.argmin(np.hypot(*(at - at.mean(axis=0)).T))]))
    return points


def _near(owners: np.ndarray, x: float, y: float, radius: float) -> set[int]:
    """The tiles showing the pixels within ``radius`` of (x, y)."""
    yy, xx = np.mgrid[: owners.shape[0], : owners.shape[1]]
    disc = (xx - x) ** 2 + (yy - y) ** 2 <= radius * radius
    return {int(k) for k in np.unique(owners[disc]) if k >= 0}


async def test_a_point_on_a_seam_is_shown_by_one_frame_once_recut(
    caplog: pytest.LogCaptureFixture,
) -> None:
    stitcher, _ = await _registered()
    points = _seam_points(stitcher.owners)
    assert len(points) >= 5  # every neighbouring pair of the 2x3 grid meets
    assert all(len(_near(stitcher.owners, x, y, 1.5)) > 1 for x, y in points)
    with caplog.at_level(logging.INFO, "cyborg.daemon.survey.stitch"):
        assert stitcher.keep_off(points)
    assert "a seam may pass" not in caplog.text  # each is inside some frame whole
    mosaic = stitcher.compose()
    owners = stitcher.owners
    for x, y in points:
        assert len(_near(owners, x, y, KEEP_OFF_PX)) == 1
    assert set(np.unique(owners)) == set(range(6))  # every tile still shows its part
    assert not stitcher.keep_off(points)  # nothing left to move
    np.testing.assert_array_equal(uncovered(mosaic), owners < 0)


async def test_a_point_no_seam_is_near_leaves_the_seams_as_they_were() -> None:
    stitcher, mosaic = await _registered()
    before = stitcher.owners.copy()
    middles = [stitcher.geometry.to_mosaic(*fit.placed) for _, fit in stitcher.tiles]
    assert all(m is not None and len(_near(before, *m, KEEP_OFF_PX)) == 1 for m in middles)
    assert not stitcher.keep_off(middles)
    np.testing.assert_array_equal(stitcher.owners, before)
    np.testing.assert_array_equal(stitcher.compose(), mosaic)


async def test_a_recut_mosaic_is_black_exactly_where_no_frame_covers() -> None:
    _, stitcher, mosaic = await _corner_missed()
    void = uncovered(mosaic)
    assert void.any()
    points = _seam_points(stitcher.owners)
    assert stitcher.keep_off(points)
    recut = stitcher.compose()
    np.testing.assert_array_equal(uncovered(recut), void)
    np.testing.assert_array_equal(stitcher.owners < 0, void)
    assert (recut != mosaic).any()  # the seams did move
