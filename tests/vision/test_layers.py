"""Layers: a thin rare bed across the view is the outcrop's structure, not a target; a vein,
a spot or a short lens is not a layer; the discount is explained."""

import numpy as np
import pytest

from cyborg.daemon.sim.regimes import REGIMES
from cyborg.daemon.sim.scene import outcrop_scene
from cyborg.daemon.vision.job import analyze_image, input_points
from cyborg.daemon.vision.layers import discount_uncommon, layer_share
from cyborg.daemon.vision.params import DEFAULT, PAPER, VisionParams
from cyborg.daemon.vision.segment import segment_plane


def _plane() -> np.ndarray:
    rng = np.random.default_rng(0)
    plane = rng.normal(100, 3, (120, 160)).clip(0, 255).astype(np.uint8)
    plane[50:58, :] = 200  # a pale bed across the view
    plane[50:58, 80] = 100  # cut in two halves by a crack the noise could make
    plane[90:91, :] = 30  # a dark line across the view: a vein or a crack, 1 px thick
    plane[20:28, 10:70] = 160  # a bed that stops: a lens, 40 % of the width
    plane[70:110, 120:128] = 240  # a thick vein from top to bottom: cuts the bedding
    return plane


def test_a_bed_across_the_view_is_a_layer_and_nothing_else_is() -> None:
    share = layer_share(segment_plane(_plane(), PAPER))
    assert np.mean(share[51:57, :] == 1.0) > 0.95  # one bed: the cut is bridged
    assert share[90, :].max() == 0.0  # thinner than a bed
    assert share[20:28, 10:70].max() == 0.0  # spans too little
    assert share[70:110, 120:128].max() == 0.0  # runs top to bottom
    assert share[0:20, :].max() == 0.0  # the commonest class never is


def test_the_discount_keeps_the_commonest_level_and_unsegmented_pixels() -> None:
    umap = np.array([[0.0, 1.0, 8.0]], np.float32)
    assert discount_uncommon(umap, np.ones_like(umap), 1.0).tolist() == [[0.0, 1.0, 1.0]]


def test_a_small_target_outranks_a_thin_rare_bed() -> None:
    """Tiny-target scene 137: a thin pink bed of rarer class than the target, across the
    whole view, was the best point (69 px from the target) without the layer discount."""
    scene = REGIMES["tiny"](137)
    target = np.argwhere(scene.target_labels > 0)

    def best_distance(params: VisionParams) -> float:
        bgr, res = analyze_image(scene.image, params)
        best = input_points(bgr.shape, res)[0]
        return float(np.hypot(*(target - (best.y, best.x)).T).min())

    assert best_distance(DEFAULT) <= 6.0
    assert best_distance(DEFAULT.replace(layers=0.0)) > 30.0


def test_a_point_on_a_layer_says_so() -> None:
    """Tiny-target scene 171: its best point is still on a bed (rare enough to lead at half
    its rarity); the explanation says that its rarity was discounted, and why."""
    _, res = analyze_image(REGIMES["tiny"](171).image, DEFAULT)
    (layer,) = [e for e in res.explanations[0] if e["plane"] == "layer"]
    assert layer["share"] >= 0.5
    assert "part of a layer across the view" in res.descriptions[0]
    _, res = analyze_image(REGIMES["tiny"](171).image, PAPER)
    assert all(e["plane"] != "layer" for e in res.explanations[0])


@pytest.mark.parametrize("value", [-0.1, 1.5, float("nan")])
def test_bad_layer_strength_is_refused(value: float) -> None:
    with pytest.raises(ValueError, match="layers"):
        DEFAULT.replace(layers=value)


def test_a_stain_on_a_bed_is_not_said_to_be_part_of_it() -> None:
    """The demo outcrop (seed 9): its wet stain lies on a bed that spans the view and shares
    the stain's hue class, but what made the stain rare is its own dark class."""
    scene = outcrop_scene(9, n_targets=3)
    (stain,) = [t for t in scene.targets if t.kind == "wet_stain"]
    bgr, res = analyze_image(scene.image, DEFAULT)
    points = input_points(bgr.shape, res)
    k = min(
        range(len(points)), key=lambda i: np.hypot(points[i].x - stain.x, points[i].y - stain.y)
    )
    assert np.hypot(points[k].x - stain.x, points[k].y - stain.y) <= stain.radius
    (layer,) = [e for e in res.explanations[k] if e["plane"] == "layer"]
    assert layer["share"] < 0.5
    assert "layer" not in res.descriptions[k]
