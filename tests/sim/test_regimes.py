"""Benchmark regimes: deterministic by seed, sized as documented, targets clear of decoys."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from bench.heldout import REGIMES as HELDOUT
from cyborg.daemon.sim.camera_effects import through_camera
from cyborg.daemon.sim.regimes import LARGE_KINDS, REGIMES, VEIN_KINDS, seed_cliff
from cyborg.daemon.sim.scene import Scene

SEEDS = range(8)


def _areas(scene: Scene) -> list[float]:
    """Share of the image each target covers, in target order."""
    return [float((scene.target_labels == i).mean()) for i in range(1, len(scene.targets) + 1)]


def _decoy_components(scene: Scene) -> int:
    return cv2.connectedComponents(scene.shadow_mask.astype(np.uint8), None, 8)[0] - 1


def test_regimes_are_named_in_report_order():
    assert list(REGIMES) == ["tiny", "seed", "large", "veins", "empty"]


@pytest.mark.parametrize(
    "gen",
    [*REGIMES.values(), *HELDOUT.values()],
    ids=[*REGIMES, *(f"heldout-{name}" for name in HELDOUT)],
)
def test_regime_is_deterministic_by_seed_and_labels_match_targets(gen):
    a, b, c = gen(5), gen(5), gen(6)
    assert np.array_equal(a.image, b.image) and a.targets == b.targets
    assert np.array_equal(a.target_labels, b.target_labels)
    assert np.array_equal(a.shadow_mask, b.shadow_mask)
    assert not np.array_equal(a.image, c.image)
    assert a.image.dtype == np.uint8 and a.image.ndim == 3 and a.seed == 5
    for scene in (a, c):
        n = len(scene.targets)
        assert sorted(np.unique(scene.target_labels)) == list(range(n + 1))
        assert scene.shadow_mask.shape == scene.target_labels.shape == scene.image.shape[:2]


@pytest.mark.parametrize("name", ["seed", "large", "veins"])
def test_targets_stay_clear_of_decoys(name):
    for s in SEEDS:
        scene = REGIMES[name](s)
        on_target = scene.target_labels > 0
        assert (on_target & scene.shadow_mask).sum() <= 0.02 * on_target.sum()


def test_seed_cliff_is_the_seed_mosaic_with_two_stains_and_one_ledge_shadow():
    for s in SEEDS:
        scene = seed_cliff(s)
        assert scene.image.shape == (108, 192, 3)
        assert [t.kind for t in scene.targets] == ["wet_stain", "wet_stain"]
        assert all(0.01 <= a <= 0.02 for a in _areas(scene))
        assert _decoy_components(scene) == 1
        # Pale and low in saturation: a gypsum/clay cliff, not red beds.
        hsv = cv2.cvtColor(scene.image, cv2.COLOR_BGR2HSV)
        rock = (scene.target_labels == 0) & ~scene.shadow_mask
        assert np.median(hsv[..., 2][rock]) > 140 and np.median(hsv[..., 1][rock]) < 50
        # The stains are darker than the rock around them.
        grey = scene.image.mean(axis=2)
        assert all(grey[scene.target_labels == i].mean() < grey[rock].mean() for i in (1, 2))


def test_large_targets_cover_five_to_fifteen_percent_each():
    for s in SEEDS:
        scene = REGIMES["large"](s)
        assert scene.image.shape == (216, 288, 3)
        assert 1 <= len(scene.targets) <= 2
        assert all(t.kind in LARGE_KINDS for t in scene.targets)
        assert all(0.05 <= a <= 0.15 for a in _areas(scene))
        assert 1 <= _decoy_components(scene) <= 4


def test_veins_are_thin_and_long_among_ledge_shadows():
    for s in SEEDS:
        scene = REGIMES["veins"](s)
        assert scene.image.shape == (216, 288, 3)
        assert 1 <= len(scene.targets) <= 2
        for i, t in enumerate(scene.targets, start=1):
            assert t.kind in VEIN_KINDS
            length = 2 * t.radius  # radius is half the vein's length
            assert 40 <= length <= 120
            # Mean width = area / length: 1.5-3 px drawn, allowing for pixel coverage.
            assert 1.0 <= (scene.target_labels == i).sum() / length <= 4.0
        assert 1 <= _decoy_components(scene) <= 4


def test_empty_has_decoys_but_no_target():
    for s in SEEDS:
        scene = REGIMES["empty"](s)
        assert scene.targets == () and not scene.target_labels.any()
        assert scene.shadow_mask.any()


def test_through_camera_vignettes_blurs_and_compresses_a_flat_scene_keeping_its_labels():
    flat = np.full((120, 160, 3), 150, np.uint8)
    labels = np.zeros((120, 160), np.uint8)
    labels[50:60, 70:80] = 1
    scene = Scene(flat, (), labels, np.zeros((120, 160), bool), 3)
    seen = through_camera(scene)
    grey = seen.image.astype(np.float32).mean(axis=2)
    corners = np.mean(
        [grey[:8, :8].mean(), grey[:8, -8:].mean(), grey[-8:, :8].mean(), grey[-8:, -8:].mean()]
    )
    assert corners < 0.9 * grey[56:64, 76:84].mean()  # the corners are darker than the centre
    assert seen.image.dtype == np.uint8 and seen.image.shape == flat.shape
    assert seen.target_labels is labels and seen.seed == 3 and seen.shadow_mask is scene.shadow_mask
    assert (through_camera(scene).image == seen.image).all()  # one camera per seed
    # The same scene under another seed is seen through another camera.
    other = through_camera(Scene(flat, (), labels, scene.shadow_mask, 4)).image
    assert (other != seen.image).any()


def test_through_camera_loses_fine_colour_detail_before_fine_brightness_detail():
    """JPEG keeps colour at half resolution and quantises it harder: a 2-px checkerboard of
    two colours of one brightness fades far more than one of two greys (blur alone would
    fade both alike)."""
    yy, xx = np.mgrid[:64, :64]
    on = (yy // 2 + xx // 2) % 2 == 0
    kept = []
    for bright, dark in (((190, 190, 190), (90, 90, 90)), ((200, 110, 110), (40, 110, 171))):
        img = np.empty((64, 64, 3), np.uint8)
        img[on], img[~on] = bright, dark
        scene = Scene(img, (), np.zeros((64, 64), np.uint8), np.zeros((64, 64), bool), 0)
        seen = through_camera(scene).image[16:48, 16:48].astype(np.float32)
        centre = on[16:48, 16:48]
        contrast = np.abs(seen[centre].mean(axis=0) - seen[~centre].mean(axis=0)).max()
        kept.append(contrast / np.abs(np.subtract(bright, dark)).max())
    grey, colour = kept
    assert grey > 0.05 and colour < 0.5 * grey


def test_a_finer_camera_keeps_more_of_what_its_jpeg_would_lose():
    """A frame twice the analysed size, reduced back, keeps about twice the fine colour
    contrast that a JPEG at the analysed size leaves; the scene's size is unchanged."""
    yy, xx = np.mgrid[:64, :64]
    on = (yy // 2 + xx // 2) % 2 == 0
    img = np.empty((64, 64, 3), np.uint8)
    img[on], img[~on] = (200, 110, 110), (40, 110, 171)  # one brightness, two colours
    scene = Scene(img, (), np.zeros((64, 64), np.uint8), np.zeros((64, 64), bool), 0)
    kept = []
    for scale in (1.0, 2.0):
        seen = through_camera(scene, ("jpeg",), scale).image
        assert seen.shape == img.shape and seen.dtype == np.uint8
        inner, centre = seen[16:48, 16:48].astype(np.float32), on[16:48, 16:48]
        kept.append(np.abs(inner[centre].mean(axis=0) - inner[~centre].mean(axis=0)).max())
    assert kept[1] > 1.5 * kept[0]
    assert (through_camera(scene, (), 2.0).image == img).all()  # no effects: the scene as it is
    for bad in (0.5, float("nan")):
        with pytest.raises(ValueError, match="scale is >= 1"):
            through_camera(scene, ("jpeg",), bad)
