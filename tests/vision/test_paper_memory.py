"""Big images are analysed a band of rows at a time, and hold no more planes than they need;
the results are, bit for bit, those of the whole-image formulation: the H, S, I planes, the
labels, the interest map and the points. And ``paper``'s peak stays under 8 bytes a pixel."""

from __future__ import annotations

import tracemalloc

import cv2
import numpy as np
import pytest

from cyborg.daemon.sim.scene import outcrop_scene
from cyborg.daemon.vision import segment
from cyborg.daemon.vision.cooccurrence import cooccurrence_histogram, diagonal_classes
from cyborg.daemon.vision.hsi import _HUE_LUT, rgb_to_hsi
from cyborg.daemon.vision.interest import interest_map, summed_uncommon
from cyborg.daemon.vision.params import DEFAULT, PAPER
from cyborg.daemon.vision.peaks import find_points
from cyborg.daemon.vision.pipeline import analyze
from cyborg.daemon.vision.uncommon import UncommonWindows, uncommon_map


def _outcrop(shape: tuple[int, int], seed: int) -> np.ndarray:
    """A seeded outcrop enlarged to ``shape``, with fresh sensor noise (as ``bench.speed``)."""
    rows, cols = shape
    base = outcrop_scene(seed, (max(8, rows // 4), max(8, cols // 4))).image
    img = cv2.resize(base, (cols, rows), interpolation=cv2.INTER_CUBIC)
    noise = np.random.default_rng(seed).normal(0, 3, img.shape).astype(np.int16)
    return np.clip(img.astype(np.int16) + noise, 0, 255).astype(np.uint8)


def test_hsi_in_bands_is_the_whole_image_formula() -> None:
    bgr = _outcrop((601, 433), 1)  # ~4 bands, the last a short one
    hsi = rgb_to_hsi(bgr, grey_saturation=9, min_intensity=30)
    b, g, r = (bgr[..., c].astype(np.uint16) for c in range(3))
    total = b + g + r
    hexcone = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV_FULL)
    assert np.array_equal(hsi.h, cv2.LUT(np.ascontiguousarray(hexcone[..., 0]), _HUE_LUT))
    assert np.array_equal(hsi.i, cv2.convertScaleAbs(total, alpha=1.0 / 3.0))
    low = np.minimum(np.minimum(b, g), r)
    assert np.array_equal(hsi.s, cv2.divide(total - 3 * low, total, scale=255.0).astype(np.uint8))
    assert np.array_equal(hsi.hue_defined, (hsi.s >= 9) & (hsi.i >= 30))


@pytest.mark.parametrize("relax", [0, 2])
def test_labels_in_bands_are_the_whole_image_labelling(relax: int) -> None:
    params = PAPER.replace(relax_passes=relax, min_votes=3)
    plane = rgb_to_hsi(_outcrop((700, 520), 2)).i
    mask = np.ones(plane.shape, bool)
    mask[300:420, 100:160] = False
    seg = segment.segment_plane(plane, params, mask=mask)
    hist = cooccurrence_histogram(plane, mask, params.cooc_max_pairs)
    peaks = diagonal_classes(hist, params)[1]
    _, u_lut = segment._value_tables(peaks, hist.sum(axis=1))
    whole = segment._label_band(plane, u_lut, mask, params)  # no band edge: the whole image
    assert seg.k >= 2
    # The same pixels hold the same classes, numbered by area: one label for each id.
    pairs = set(zip(whole.ravel().tolist(), seg.labels.ravel().tolist(), strict=True))
    assert len(pairs) == len({w for w, _ in pairs}) == seg.k + 1
    assert [c.area for c in seg.classes] == [
        int((seg.labels == k).sum()) for k in range(1, seg.k + 1)
    ]


@pytest.mark.parametrize("blur", [10.0, 40.0])
@pytest.mark.parametrize("params", [PAPER, DEFAULT], ids=["paper", "default"])
def test_interest_summed_in_bands_is_the_whole_sum(params, blur: float) -> None:
    params = params.replace(blur=blur, blur_fraction=0.0, texture_weight=0.0, line_weight=0.0)
    hsi = rgb_to_hsi(_outcrop((1203, 611), 3))
    segs = tuple(segment.segment_plane(p, params) for p in hsi.planes)
    banded = interest_map(segs, params)
    whole = interest_map(segs, params, summed_uncommon(segs, params))
    assert banded.factor == whole.factor > 1
    for a, b in ((banded.grid, whole.grid), (banded.blurred, whole.blurred)):
        assert (a is None and b is None) or np.array_equal(a, b)
    box = np.s_[100:180, 30:95]
    for seg in segs:
        assert np.array_equal(UncommonWindows(seg, params)[box], uncommon_map(seg, params)[box])


def test_a_big_image_gives_what_its_whole_image_formulation_gives() -> None:
    bgr = _outcrop((1500, 3000), 4)  # over the size whose planes are kept
    res = analyze(bgr, PAPER)
    assert res.planes is None
    hsi = rgb_to_hsi(bgr)
    for made, expected in zip(res.hsi.planes, hsi.planes, strict=True):
        assert np.array_equal(made, expected)
    assert all(seg.values is None for seg in res.segmentations)  # paper reads no values
    imap = interest_map(res.segmentations, PAPER, summed_uncommon(res.segmentations, PAPER))
    assert np.array_equal(res.interest.grid, imap.grid)
    assert [(p.x, p.y, p.score) for p in res.points] == [
        (p.x, p.y, p.score) for p in find_points(imap, PAPER)
    ]


def test_paper_peak_is_under_8_bytes_per_pixel() -> None:
    bgr = _outcrop((2000, 3000), 5)
    analyze(bgr[:64, :64], PAPER)  # first-call caches out of the measure
    tracemalloc.start()
    try:
        res = analyze(bgr, PAPER)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert res.points
    assert peak / bgr[..., 0].size < 8.0
