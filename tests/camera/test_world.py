"""The procedural world: detail that resolves only close up, no edge, deterministic; and the
simulated camera drawing it at the ground resolution of each view."""

from __future__ import annotations

import numpy as np

from cyborg.daemon.camera import open_camera
from cyborg.daemon.sim.world import World

FAR, NEAR = 30.0 / 720, 1.0 / 720
"""Pixel footprints (degrees) of a 720 px wide, 30 deg view at 300 m and at 10 m."""


def _grid(pan: float, tilt: float, half: float, footprint: float) -> tuple[np.ndarray, np.ndarray]:
    n = max(2, round(2 * half / footprint))
    offsets = (np.arange(n) + 0.5) * footprint - half
    return np.meshgrid(pan + offsets, tilt - offsets)


def test_thin_veins_resolve_only_close_up() -> None:
    world = World(4)
    veins = next(f for f in world.features if f.kind == "veins")
    near = world.render(*_grid(veins.pan, veins.tilt, 0.5, NEAR), NEAR)
    far = world.render(*_grid(veins.pan, veins.tilt, 0.5, FAR), FAR)
    # At 10 m a vein pixel is white; at 300 m a 0.004 deg vein is a tenth of a pixel: faint.
    assert near.min(axis=2).max() >= 225
    assert far.min(axis=2).max() < 205


def test_the_stain_core_is_the_close_range_feature() -> None:
    world = World(7)
    stain = world.target
    assert stain.kind == "wet_stain" and stain.close is not None
    pan, tilt, radius = stain.close
    assert np.hypot(pan - stain.pan, tilt - stain.tilt) < stain.radius - radius
    view = world.render(*_grid(pan, tilt, 3 * radius, NEAR), NEAR)
    centre = view[view.shape[0] // 2, view.shape[1] // 2].astype(int)
    rim = view[view.shape[0] // 2, 2].astype(int)  # wet rock beside the core
    assert centre.sum() < 180 and centre[0] > centre[2]  # dark and bluish
    assert rim.sum() > centre.sum() + 30


def test_a_ledge_shadow_is_lit_by_the_sky() -> None:
    """As in every simulated scene (``daemon.scene.SKY_SHADE``): darker than its rock and
    bluer, as shade on a clear day is."""
    world = World(3)
    ledge = next(f for f in world.features if f.kind == "ledge_shadow")
    view = world.render(*_grid(ledge.pan, ledge.tilt, 2 * ledge.radius, FAR), FAR)
    rows, cols = view.shape[:2]
    inside = view[rows // 2, cols // 2].astype(float)
    beside = view[rows // 2, 2].astype(float)  # the same bed, past the shadow's end
    assert inside.sum() < 0.6 * beside.sum()
    assert inside[0] / inside[2] > 1.2 * beside[0] / beside[2]


def test_deterministic_by_seed_and_without_edge() -> None:
    a, b, c = World(3), World(3), World(4)
    grid = _grid(0.0, 0.0, 20.0, FAR)
    assert np.array_equal(a.render(*grid, FAR), b.render(*grid, FAR))
    assert not np.array_equal(a.render(*grid, FAR), c.render(*grid, FAR))
    # Far beyond any panorama's extent there is still rock with grain, not a smeared edge.
    far_side = a.render(*_grid(170.0, -40.0, 2.0, FAR), FAR).astype(np.float32)
    assert far_side.std(axis=0).min() > 0.5 and far_side.std(axis=1).min() > 0.5


async def test_the_simulated_camera_draws_the_world_at_each_zoom() -> None:
    world = World(3)
    pan, tilt, radius = world.target.close
    cam = open_camera("sim://world?seed=3&noise=0&width=360&height=288&hfov=30")
    cam.fixed_pose = (pan, tilt)
    wide = (await cam.grab()).image
    await cam.zoom(30.0)
    close = (await cam.grab()).image

    def dark(img: np.ndarray, half: int) -> float:
        mid = img[144 - half : 144 + half, 180 - half : 180 + half].astype(int).sum(axis=2)
        return float((mid < 180).mean())

    # Zoomed 30x, the core (radius > 12 px at 1/360 deg per pixel) fills the middle of the
    # frame; from afar it is a dot of one or two pixels in the middle of the stain.
    assert radius / (1.0 / 360) > 12
    assert dark(close, 12) > 0.95 and dark(wide, 12) < 0.1


def test_grain_is_albedo_not_grey() -> None:
    """Grain and lamination scale a bed's three channels alike: across a patch of one bed the
    brightness varies while the chromaticity does not (added grey levels would grey a
    coloured bed where light and saturate it where dark)."""
    world = World(1)  # red beds (B / R about 0.4), where greying would show most
    view = world.render(*_grid(170.0, -40.0, 0.3, FAR), FAR).astype(np.float64)
    grey = view.mean(axis=2)
    ratio = view[..., 0] / view[..., 2]
    one_bed = np.abs(ratio - np.median(ratio)) < 0.05  # a contact may cross the patch
    assert one_bed.mean() > 0.5
    assert grey[one_bed].std() > 3.0  # grain there is
    assert ratio[one_bed].std() < 0.01  # and it does not move the colour
