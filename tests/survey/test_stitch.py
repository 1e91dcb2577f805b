"""The registered mosaic on frames of the simulated cliff shot from poses the head got wrong:
corrections recovered, a textureless frame left where the head says (and saying so), what no
frame covers black and masked as no-data."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from cyborg.daemon.camera.simulated import PAN, TILT, Imperfections, Panorama, SimulatedCamera
from cyborg.daemon.pointing.geometry import CameraModel, SphericalMosaic, angles_to_pixel
from cyborg.daemon.sim.camera_effects import vignette
from cyborg.daemon.survey.stitch import Stitcher
from cyborg.daemon.vision.nodata import no_data_mask

CAM = CameraModel(720, 576, 30.0)


async def _stitch(
    camera: SimulatedCamera, g: SphericalMosaic, errors: np.ndarray
) -> tuple[Stitcher, np.ndarray]:
    """Every tile shot ``errors`` (degrees, one (pan, tilt) per tile) away from its planned
    pose, which is what is recorded; the stitcher and its mosaic."""
    stitcher = Stitcher(g)
    for (row, col), error in zip(g.serpentine(), errors, strict=True):
        pose = g.tile_pose(row, col)
        camera.fixed_pose = (pose[0] + error[0], pose[1] + error[1])
        stitcher.add(row, col, (await camera.grab()).image, pose)
    return stitcher, stitcher.compose()


def _errors(n: int, seed: int) -> np.ndarray:
    """A head's pointing errors, 0.3° per axis; none on the first tile, which anchors."""
    errors = np.random.default_rng(seed).normal(0.0, 0.3, (n, 2))
    errors[0] = 0.0
    return errors


@pytest.mark.parametrize("seed", [1, 2])
async def test_pose_errors_are_recovered_and_the_target_lands_where_the_mosaic_says(
    seed: int,
) -> None:
    camera = SimulatedCamera.from_url("sim://outcrop?seed=5&noise=2")
    plant = next(t for t in camera.panorama.targets if t.kind == "plant")
    g = SphericalMosaic(CAM, 2, 3, plant.pan - 7.0, plant.tilt + 3.0, 4.0, overlap=0.3)
    errors = _errors(6, seed)
    stitcher, mosaic = await _stitch(camera, g, errors)
    per_deg = g.scale * math.pi / 180.0
    for (_, fit), error in zip(stitcher.tiles[1:], errors[1:], strict=True):
        assert fit.registered and fit.confidence >= 0.5 and not fit.note
        assert np.hypot(*(np.subtract(fit.correction_deg, error))) * per_deg < 1.0
        assert fit.shift_px == pytest.approx((error[0] * per_deg, -error[1] * per_deg), abs=1.0)
    where = g.to_mosaic(plant.pan, plant.tilt)
    b, gr, r = (mosaic[..., i].astype(int) for i in range(3))
    ys, xs = np.nonzero((gr > r + 30) & (gr > b + 30))
    assert np.hypot(xs.mean() + 0.5 - where[0], ys.mean() + 0.5 - where[1]) < 1.5


async def test_a_textureless_frame_stays_at_its_pose_and_says_so() -> None:
    flat = Panorama(np.full((1248, 2400, 3), 128, np.uint8), PAN, TILT)
    camera = SimulatedCamera(flat, CAM, noise=2.0, seed=3)
    g = SphericalMosaic(CAM, 1, 3, 0.0, 0.0, 4.0, overlap=0.3)
    stitcher, mosaic = await _stitch(camera, g, _errors(3, 4))
    for _, fit in stitcher.tiles[1:]:
        assert not fit.registered and fit.correction_deg == (0.0, 0.0)
        assert "textureless" in fit.note and fit.record()["note"] == fit.note
    assert mosaic.any(axis=2).mean() > 0.9


async def test_what_no_frame_covers_is_black_and_masked() -> None:
    camera = SimulatedCamera.from_url("sim://outcrop?seed=3&noise=2")
    g = SphericalMosaic(CAM, 2, 3, 0.0, 3.0, 4.0, overlap=0.3)
    errors = _errors(6, 5)
    errors[-1] = (1.9, 0.3)  # the bottom-left tile, shot right, misses the left edge
    stitcher, mosaic = await _stitch(camera, g, errors)
    assert stitcher.tiles[-1][1].registered
    (u0, v0), (width, height) = g.origin, g.size
    pan = np.degrees((u0 + np.arange(width)) / g.scale)[None, :]
    tilt = np.degrees(math.pi / 2 - (v0 + np.arange(height)) / g.scale)[:, None]
    pan, tilt = np.broadcast_arrays(pan, tilt)

    def seen(margin: float) -> np.ndarray:
        """Mosaic pixels more than ``margin`` camera pixels inside a frame as placed."""
        out = np.zeros((height, width), bool)
        for _, fit in stitcher.tiles:
            x, y = angles_to_pixel(pan, tilt, *fit.placed, CAM)
            x_in = (x > margin) & (x < CAM.width - margin)
            out |= x_in & (y > margin) & (y < CAM.height - margin)
        return out

    outside, inside = ~seen(-12.0), seen(12.0)
    assert outside.any() and not mosaic[outside].any()
    assert mosaic[inside].any(axis=1).all()
    mask = no_data_mask(mosaic)
    assert mask is not None and not mask[inside].any()
    # Every uncovered corner is fill, bar specks too small for the science to call fill.
    n, labels, stats, _ = cv2.connectedComponentsWithStats(outside.astype(np.uint8))
    large = [k for k in range(1, n) if stats[k, cv2.CC_STAT_AREA] >= 0.0025 * outside.size]
    assert large and all(mask[labels == k].all() for k in large)


async def test_seams_keep_off_a_ledge_in_the_overlap() -> None:
    """A dark ledge along the rows' overlap under a vignetting, drifting camera: on colour
    the seam would follow the ledge (its levels differ least there) where the science looks;
    it crosses plain rock instead. Seams are cut as the tiles arrive: every pixel a frame
    covers has its owner before the mosaic is composed."""
    rng = np.random.default_rng(7)
    rock = cv2.GaussianBlur(rng.normal(150.0, 25.0, (1248, 2400)), (0, 0), 2.0)
    ledge = np.abs(np.linspace(TILT[1], TILT[0], 1248))[:, None] < 0.6
    grey = np.clip(np.where(ledge, rock * 0.3, rock), 0, 255).astype(np.uint8)
    flaws = Imperfections(vignetting=0.25, ae_lag=0.5, ae_walk=0.03)
    camera = SimulatedCamera(
        Panorama(cv2.merge([grey] * 3), PAN, TILT), CAM, seed=2, imperfections=flaws
    )
    g = SphericalMosaic(CAM, 2, 3, 0.0, 0.0, 4.0, overlap=0.3)
    stitcher = Stitcher(g)
    for row, col in g.serpentine():
        camera.fixed_pose = g.tile_pose(row, col)
        stitcher.add(row, col, (await camera.grab()).image, g.tile_pose(row, col))
    assert (stitcher.owners >= 0).all()  # the canvas is cropped to what the tiles cover
    mosaic = stitcher.compose()
    assert mosaic.any(axis=2).all()
    owners = stitcher.owners
    across = owners[1:] != owners[:-1]  # a horizontal seam between these rows
    height = owners.shape[0]
    tilt = np.degrees(math.pi / 2 - (g.origin[1] + np.arange(1, height)) / g.scale)
    near = np.abs(tilt) < 0.6 + 3 * g.degrees_per_pixel
    assert across.sum() > g.size[0]  # the rows do meet along a seam
    assert across[near].sum() < 0.2 * across.sum()


@pytest.mark.parametrize("corner", [0.0, 0.25])
async def test_the_lens_falloff_is_measured_on_the_overlaps_and_divided_out(
    corner: float,
) -> None:
    """Frames of a camera whose corners are ``corner`` darker, its exposure drifting between
    frames: the falloff the overlaps show is the lens's, whatever the rock and the gains,
    and none is invented for a lens without one."""
    flaws = Imperfections(vignetting=corner, ae_lag=0.5, ae_walk=0.03)
    camera = SimulatedCamera.from_url("sim://outcrop?seed=4&noise=2")
    camera = SimulatedCamera(camera.panorama, CAM, noise=2.0, seed=4, imperfections=flaws)
    g = SphericalMosaic(CAM, 2, 3, 0.0, 0.0, 4.0, overlap=0.3)
    stitcher, mosaic = await _stitch(camera, g, _errors(6, 6))
    assert mosaic.any()
    measured = stitcher.vignetting
    if measured is None:  # a fit brightening the corners is rejected
        assert corner == 0.0
    else:
        assert np.abs(measured - vignette(*measured.shape, corner)).max() < 0.03


async def test_a_point_is_reached_through_the_correction_of_the_tile_that_shows_it() -> None:
    camera = SimulatedCamera.from_url("sim://outcrop?seed=5&noise=2")
    g = SphericalMosaic(CAM, 2, 3, 10.0, 2.0, 4.0, overlap=0.3)
    stitcher, _ = await _stitch(camera, g, _errors(6, 1))
    for k, (_, fit) in enumerate(stitcher.tiles):
        where = g.to_mosaic(*fit.placed)  # the middle of tile k, which it alone shows
        assert where is not None and stitcher.owners[int(where[1]), int(where[0])] == k
        assert stitcher.correction_at(*fit.placed) == fit.correction_deg
    assert any(fit.correction_deg != (0.0, 0.0) for _, fit in stitcher.tiles)
    assert stitcher.correction_at(10.0 + 90.0, 2.0) == (0.0, 0.0)  # off the canvas


async def test_a_plain_world_composes_plain_up_to_the_frames_edges() -> None:
    """Where a seam meets a frame's edge (here the canvas's sides) the blend's coarser bands
    reach past the frame: what they find there is the frame reflected, not black, so no dark
    line is drawn for the science to take for a feature."""
    flat = Panorama(np.full((1248, 2400, 3), 128, np.uint8), PAN, TILT)
    camera = SimulatedCamera(flat, CAM, noise=2.0, seed=3)
    g = SphericalMosaic(CAM, 2, 3, 0.0, 0.0, 4.0, overlap=0.3)
    stitcher = Stitcher(g, register=False, flatten=False)
    for row, col in g.serpentine():
        camera.fixed_pose = g.tile_pose(row, col)
        stitcher.add(row, col, (await camera.grab()).image, g.tile_pose(row, col))
    mosaic = stitcher.compose()
    assert (stitcher.owners >= 0).all()
    assert np.abs(mosaic.astype(int) - 128).max() <= 8
