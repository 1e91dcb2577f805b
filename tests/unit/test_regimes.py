"""Benchmark regimes: deterministic by seed, sized as documented, targets clear of decoys."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from daemon.regimes import LARGE_KINDS, REGIMES, VEIN_KINDS, seed_cliff
from daemon.scene import Scene

SEEDS = range(8)


def _areas(scene: Scene) -> list[float]:
    """Share of the image each target covers, in target order."""
    return [float((scene.target_labels == i).mean()) for i in range(1, len(scene.targets) + 1)]


def _decoy_components(scene: Scene) -> int:
    return cv2.connectedComponents(scene.shadow_mask.astype(np.uint8), None, 8)[0] - 1


def test_regimes_are_named_in_report_order():
    assert list(REGIMES) == ["tiny", "seed", "large", "veins", "empty"]


@pytest.mark.parametrize("name", list(REGIMES))
def test_regime_is_deterministic_by_seed_and_labels_match_targets(name):
    gen = REGIMES[name]
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
