"""The one-pass kernels of ``default``'s speed work give what the passes they replace gave, bit
for bit: the layers' cores and discounts, the uncommon map's lookups, the shadow gate's thin
dark lines, its last maximum and its lit rock's block means, texture's block means of its
moments, and the segmentation's class areas."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from cyborg.daemon.sim.scene import outcrop_scene
from cyborg.daemon.vision import layers, segment, shadow, texture
from cyborg.daemon.vision.cooccurrence import Segmentation
from cyborg.daemon.vision.grid import block_means
from cyborg.daemon.vision.params import DEFAULT, PAPER
from cyborg.daemon.vision.pipeline import analyze
from cyborg.daemon.vision.uncommon import uncommon_map, uncommon_values, value_rarity


def _segmentations() -> list[Segmentation]:
    """The H, S, I segmentations of seeded outcrops (odd sides too) under both profiles,
    of bedded planes (beds across the view, broken and thin ones) and their transposes."""
    segs = []
    for seed in range(3):
        image = outcrop_scene(seed, (90 + 11 * seed, 130 - 7 * seed)).image
        for params in (DEFAULT, PAPER):
            segs.extend(analyze(image, params).segmentations)
    rng = np.random.default_rng(5)
    for _ in range(6):
        plane = np.full((120, 160), 100, np.uint8)
        for _ in range(4):
            top, thick = int(rng.integers(0, 110)), int(rng.integers(1, 12))
            left, right = sorted(rng.integers(0, 161, 2).tolist())
            plane[top : top + thick, left:right] = int(rng.integers(0, 256))
        plane[rng.random(plane.shape) < 0.01] = 30  # specks break the beds
        segs.append(segment.segment_plane(plane, PAPER))
    flipped = [Segmentation(np.ascontiguousarray(s.labels.T), s.classes, s.histogram) for s in segs]
    return segs + flipped


def reference_layer_share(seg: Segmentation) -> np.ndarray:
    """``layers.layer_share`` with each class's core by its own mask's erosion."""
    rows, cols = seg.labels.shape
    diag = math.hypot(rows, cols)
    share = np.zeros((rows, cols), np.float32)
    size = 2 * layers._BRIDGE + 1
    bridge = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    for k in range(2, seg.k + 1):
        mask = cv2.compare(seg.labels, k, cv2.CMP_EQ)
        core = cv2.erode(mask, None)
        if cv2.countNonZero(cv2.reduce(core, 0, cv2.REDUCE_MAX)) <= layers._SPAN[0] * cols:
            continue
        ys = np.flatnonzero(cv2.reduce(core, 1, cv2.REDUCE_MAX))
        r0, r1 = max(0, ys[0] - 2 * layers._BRIDGE), min(rows, ys[-1] + 2 * layers._BRIDGE + 1)
        mask = mask[r0:r1]
        _, regions, stats, _ = cv2.connectedComponentsWithStats(
            cv2.dilate(mask, bridge), connectivity=8
        )
        for j in np.nonzero(stats[1:, cv2.CC_STAT_WIDTH] > layers._SPAN[0] * cols)[0] + 1:
            width = int(stats[j, cv2.CC_STAT_WIDTH])
            region = (regions == j) & (mask > 0)
            thick = float(np.count_nonzero(region)) / width / diag
            s = layers._ramp(width / cols, *layers._SPAN) * layers._ramp(thick, *layers._THICK)
            if s > 0:
                share[r0:r1][region] = s
    return share


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)


def test_layer_shares_are_the_per_class_erosions() -> None:
    segs = _segmentations()
    for seg in segs:
        assert _same(layers.layer_share(seg), reference_layer_share(seg))
    assert sum(bool(layers.layer_share(s).any()) for s in segs) >= 5  # layers were found


def test_the_discounts_are_the_array_expressions() -> None:
    rng = np.random.default_rng(6)
    umap = rng.choice(np.float32([0.0, 1.0, 2.5, 8.0, 11.5]), (70, 90))
    shares = [rng.choice(np.float32([0.0, 0.3, 1.0]), (70, 90)) for _ in range(3)]
    texture = rng.gamma(1.0, 3.0, (70, 90)).astype(np.float32)
    expected = umap - np.maximum(umap - np.float32(1.0), 0) * (shares[0] * np.float32(0.5))
    assert _same(layers.discount_uncommon(umap, shares[0], 0.5), expected)
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * layers._CONTACT + 1,) * 2)
    near = cv2.dilate(np.maximum.reduce(shares), disc)
    expected = texture * (1.0 - near * np.float32(0.5 * layers._TEXTURE_SHARE))
    assert _same(layers.discount_texture(texture, shares, 0.5), expected)


def test_the_uncommon_map_is_its_lookups_whole_and_by_window() -> None:
    for seg in _segmentations()[:18]:
        table = uncommon_values(seg, DEFAULT).astype(np.float32)
        expected = cv2.LUT(seg.labels, table)
        if seg.values is not None and seg.k:
            tail = cv2.LUT(seg.values, value_rarity(seg, DEFAULT) * np.float32(0.5))
            expected += cv2.bitwise_and(tail, tail, mask=cv2.compare(seg.labels, 0, cv2.CMP_GT))
        assert _same(uncommon_map(seg, DEFAULT), expected)
        box = np.s_[3:40, 5:61]
        assert _same(uncommon_map(seg.window(box), DEFAULT), expected[box])


@pytest.mark.parametrize("level", [0.0, 0.2, 0.35])
def test_the_shadow_gates_lines_and_maximum_are_the_index_expressions(level: float) -> None:
    rng = np.random.default_rng(7)
    deficit = cv2.GaussianBlur(rng.normal(0, 0.3, (80, 110)).astype(np.float32), (0, 0), 1.2)
    deficit += np.float32(level)
    deficit[40:42, 5:100] = 1.0  # a crack standing alone
    dark = (deficit > np.float32(shadow._DARK)).astype(np.uint8)
    n, labels = cv2.connectedComponents(dark, connectivity=8)
    body = np.zeros(n, np.uint8)
    opened = cv2.morphologyEx(dark, cv2.MORPH_OPEN, shadow._disc(shadow._THIN))
    body[labels[opened > 0]] = 1
    expected = cv2.dilate(dark - body[labels], shadow._disc(shadow._EDGE))
    lines = shadow._dark_lines(deficit)
    assert _same(lines, expected) and lines.any()
    tinted, untinted = (rng.random((80, 110)).astype(np.float32) ** 4 for _ in range(2))
    masked = untinted.copy()
    masked[lines > 0] = 0.0
    assert _same(shadow._either(tinted, untinted, lines), cv2.max(tinted, masked))


def test_the_lit_rocks_block_means_are_the_weighted_copys() -> None:
    rng = np.random.default_rng(8)
    for _ in range(24):  # odd and even sides: the padding's mirrored row and column too
        rows, cols = (int(v) for v in rng.integers(16, 160, 2))
        logs = rng.normal(3.0, 1.0, (rows, cols, 3)).astype(np.float32)
        brightness, level = (rng.normal(0.0, 0.2, (rows, cols)).astype(np.float32) for _ in "bl")
        expected = block_means(shadow._lit_weighted(logs, brightness, level), 2)
        assert _same(shadow._lit_blocks(logs, brightness, level), expected)


def test_textures_moment_blocks_are_the_block_means_of_its_moments() -> None:
    rng = np.random.default_rng(9)
    for _ in range(24):
        rows, cols = (int(v) for v in rng.integers(16, 160, 2))
        planes = rng.normal(0.0, 1.0, (rows, cols, 5)).astype(np.float32)
        expected = block_means(np.ascontiguousarray(planes[..., :2]), 2)
        assert _same(texture._moment_blocks(planes), expected)


def test_the_class_areas_are_one_count_per_class() -> None:
    for seg in _segmentations()[:18]:
        labels = seg.labels
        areas = [cv2.countNonZero(cv2.compare(labels, k, cv2.CMP_EQ)) for k in range(1, seg.k + 1)]
        assert [c.area for c in seg.classes] == areas
