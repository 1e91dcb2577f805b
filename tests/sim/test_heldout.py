"""The held-out generator (``bench.heldout``): the same regimes as ours, drawn apart."""

import cv2
import numpy as np
import pytest

from bench.heldout import DESCRIPTIONS, REGIMES, SEED_SHAPE, seed_cliff
from cyborg.daemon.sim.regimes import REGIMES as OURS

SEEDS = range(12)


def test_regimes_are_ours_and_each_is_described():
    # Determinism and labels: tests/unit/test_regimes.py, for both generators.
    assert list(REGIMES) == list(OURS)
    assert set(DESCRIPTIONS) == set(REGIMES)
    for name, gen in REGIMES.items():
        scene = gen(3)
        shape = SEED_SHAPE if name == "seed" else (216, 288)
        assert scene.image.shape == (*shape, 3) and scene.shadow_mask.any()


def test_the_seed_cliff_is_pale_with_two_dark_stains_and_the_shadow_changes_nothing_else():
    for s in SEEDS:
        lit, shaded = seed_cliff(s, shadow=False), seed_cliff(s)
        assert not lit.shadow_mask.any() and shaded.shadow_mask.any()
        assert (lit.target_labels == shaded.target_labels).all()
        outside = ~shaded.shadow_mask
        assert (lit.image[outside] == shaded.image[outside]).all()
        grey = lit.image.astype(np.float32).mean(axis=2)
        hsv = cv2.cvtColor(lit.image, cv2.COLOR_BGR2HSV)
        assert [t.kind for t in lit.targets] == ["wet_stain"] * 2
        rock = lit.target_labels == 0
        assert np.median(hsv[..., 1][rock]) < 0.25 * 255  # pale, low-saturation beds
        ring = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7))
        for i in (1, 2):
            stain = lit.target_labels == i
            assert 0.01 <= stain.mean() <= 0.02
            around = cv2.dilate(stain.astype(np.uint8), ring).astype(bool) & rock
            assert grey[stain].mean() < 0.85 * grey[around].mean()  # wet is darker
            near = cv2.dilate(stain.astype(np.uint8), ring).astype(bool)
            assert not (near & shaded.shadow_mask).any()


@pytest.mark.parametrize("name", ["tiny", "large", "veins"])
def test_every_scene_has_a_target_clear_of_shadows_and_of_the_frame(name):
    clear = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (9, 9))
    for s in SEEDS:
        scene = REGIMES[name](s)
        assert 1 <= len(scene.targets) <= (2 if name != "tiny" else 3)
        near = cv2.dilate((scene.target_labels > 0).astype(np.uint8), clear).astype(bool)
        assert not (near & scene.shadow_mask).any()
        ys, xs = np.nonzero(scene.target_labels)
        assert ys.min() > 0 and xs.min() > 0 and ys.max() < 215 and xs.max() < 287


def test_sizes_are_the_regimes_own():
    area = 216 * 288
    for s in SEEDS:
        tiny = REGIMES["tiny"](s)
        for i, t in enumerate(tiny.targets, start=1):
            assert 3 <= t.radius <= 9 and (tiny.target_labels == i).sum() < 300
        large = REGIMES["large"](s)
        for i in range(1, len(large.targets) + 1):
            assert 0.05 <= (large.target_labels == i).sum() / area <= 0.15
        veins = REGIMES["veins"](s)
        for i, t in enumerate(veins.targets, start=1):
            pixels = (veins.target_labels == i).sum()
            assert 15 <= t.radius <= 65 and pixels / (2 * t.radius) < 4  # long and thin


def test_empty_has_shadows_and_nothing_else():
    for s in SEEDS:
        scene = REGIMES["empty"](s)
        assert scene.targets == () and not scene.target_labels.any()
        # A shadow hangs from a contact onto the bed below it: darker than that bed, lit, a
        # little further down (shadows are at most 12 px thick).
        rows, cols = np.nonzero(scene.shadow_mask)
        grey = scene.image.astype(np.float32).mean(axis=2)
        below = np.clip(rows + 14, None, 215)
        assert grey[rows, cols].mean() < 0.8 * grey[below, cols].mean()
