import cv2
import numpy as np
import pytest

from daemon.vision.cooccurrence import PlaneClass, Segmentation
from daemon.vision.interest import (
    InterestMap,
    describe,
    find_points,
    interest_map,
    summed_uncommon,
)
from daemon.vision.params import DEFAULT, PAPER
from daemon.vision.pipeline import analyze, as_bgr8
from daemon.vision.uncommon import uncommon_map


def rock_with_blob(rng, size=12, blob_colour=(40, 160, 40)):
    """Two noisy beds and a green blob of side ``size`` centred on (x, y) = (35.5, 85.5)."""
    img = np.empty((120, 160, 3), np.float64)
    img[:60] = (60, 110, 160)
    img[60:] = (120, 150, 170)
    img += rng.normal(0, 3, img.shape)
    lo, hi = 86 - size // 2, 86 + size // 2
    img[lo:hi, 36 - size // 2 : 36 + size // 2] = blob_colour
    return np.clip(img, 0, 255).astype(np.uint8)


# The blob is matched to each profile's blur scale B (10 px for paper, 3 px for default).
@pytest.mark.parametrize(("params", "size"), [(PAPER, 24), (DEFAULT, 12)])
def test_odd_coloured_blob_is_the_top_point(rng, params, size):
    res = analyze(rock_with_blob(rng, size), params)
    top = res.points[0]
    assert abs(top.x - 35.5) < 4 and abs(top.y - 85.5) < 4
    assert [p.rank for p in res.points] == list(range(1, len(res.points) + 1))
    scores = [p.score for p in res.points]
    assert scores == sorted(scores, reverse=True)
    contributions = {e["plane"]: e["contribution"] for e in res.explanations[0]}
    assert set(contributions) == {"H", "S", "I"}
    assert max(contributions.values()) > 0


def test_decimated_blur_matches_exact_blur(rng):
    res = analyze(rock_with_blob(rng, 24), PAPER)
    fast = interest_map(res.segmentations, PAPER)
    exact = interest_map(res.segmentations, PAPER.replace(exact_blur=True))
    assert fast.factor == 4 and exact.factor == 1
    err = np.abs(fast.full() - exact.full())
    assert err.max() < 0.05 * exact.grid.max()
    p_fast, p_exact = find_points(fast, PAPER)[0], find_points(exact, PAPER)[0]
    assert abs(p_fast.x - p_exact.x) < 1.5 and abs(p_fast.y - p_exact.y) < 1.5


def test_points_respect_separation(rng):
    img = rng.integers(0, 256, (100, 100, 3), dtype=np.uint8)
    pts = analyze(img, PAPER.replace(top_n=10)).points
    for i, a in enumerate(pts):
        for b in pts[i + 1 :]:
            assert np.hypot(a.x - b.x, a.y - b.y) >= PAPER.separation - 2  # sub-pixel refinement


@pytest.mark.parametrize(
    "image",
    [
        np.full((40, 50, 3), 128, np.uint8),  # constant
        np.zeros((1, 1, 3), np.uint8),  # 1x1
        np.zeros((1, 30, 3), np.uint8),  # one row
    ],
)
@pytest.mark.parametrize("params", [PAPER, DEFAULT])
def test_flat_and_tiny_images_give_no_points(image, params):
    res = analyze(image, params)
    assert res.points == []
    assert np.isfinite(res.interest.full()).all()


def test_grey_16bit_and_rgba_inputs(rng):
    grey = rng.integers(0, 65536, (30, 40), dtype=np.uint16)
    grey[10:16, 10:16] = 65535
    res = analyze(as_bgr8(grey), DEFAULT)
    assert res.hsi.h.shape == (30, 40)
    rgba = np.dstack([rock_with_blob(rng), np.full((120, 160), 255, np.uint8)])
    top = analyze(as_bgr8(rgba), DEFAULT).points[0]
    assert abs(top.x - 35.5) < 4 and abs(top.y - 85.5) < 4
    with pytest.raises(ValueError):
        as_bgr8(np.zeros((3, 3, 5), np.uint8))
    with pytest.raises(ValueError):
        analyze(np.zeros((3, 3), np.uint8), DEFAULT)


def test_white_spot_is_explained_as_a_grey_hue_class(rng):
    img = rock_with_blob(rng, 12, blob_colour=(235, 235, 235))
    res = analyze(img, DEFAULT)
    h = next(e for e in res.explanations[0] if e["plane"] == "H")
    assert h["value"] == "grey"
    assert "H class" in describe(res.explanations[0]) and "(grey," in describe(res.explanations[0])


def test_blob_scoring_prefers_a_compact_spot_to_a_ledge_shadow(rng):
    """A bluish ledge shadow across the frame is rare in H, S and I, a plant of the rock's
    brightness mostly in H: the shadow wins the plain blurred sum, the plant wins with blob
    scoring, and the decimated grid agrees with the full-resolution one. (A shadow that ends
    inside the frame keeps some score at its two rounded ends: half a blob each.)"""
    img = np.empty((120, 200, 3), np.float64)
    img[:] = (60, 110, 160)
    img += rng.normal(0, 3, img.shape)
    img[30:38] = (70, 40, 30)  # a ledge shadow, 8 px high, across the frame
    img[80:90, 95:105] = (60, 160, 110)  # a plant, 10 px across
    img = np.clip(img, 0, 255).astype(np.uint8)
    plain = analyze(img, DEFAULT.replace(blob=False))
    assert abs(plain.points[0].y - 34) < 5, "without blob scoring the shadow wins"
    res = analyze(img, DEFAULT)
    top = res.points[0]
    assert abs(top.x - 99.5) < 3 and abs(top.y - 84.5) < 3
    grid = res.interest.full()
    assert grid[34, 100] < 0.05 * grid[85, 100]  # the shadow's middle is a ridge: ~0
    exact = interest_map(res.segmentations, DEFAULT.replace(exact_blur=True))
    assert abs(find_points(exact, DEFAULT)[0].x - top.x) < 1.5


def test_partial_sort_of_peaks_picks_what_a_full_sort_picks(rng):
    """Hundreds of peaks with many tied values: the top-k shortcut must not change the pick."""
    grid = np.round(rng.random((200, 240)) * 8).astype(np.float32)  # 9 levels: ties galore
    params = PAPER.replace(blur=2.0, top_n=40)
    picked = find_points(InterestMap(grid, 1, grid.shape), params)
    local = cv2.dilate(grid, np.ones((5, 5), np.uint8))
    rows, cols = np.nonzero((grid >= local) & (grid > grid.min() + 1e-3 * np.ptp(grid)))
    expected: list[tuple[int, int]] = []
    for i in np.lexsort((cols, rows, -grid[rows, cols])):
        r, c = int(rows[i]), int(cols[i])
        if all((r - y) ** 2 + (c - x) ** 2 >= 4.0 for x, y in expected):
            expected.append((c, r))
    assert len(rows) > 32 * params.top_n and len(picked) == params.top_n
    for point, (x, y) in zip(picked, expected, strict=False):  # refinement moves <= 0.5 px
        assert abs(point.x - x) <= 0.5 and abs(point.y - y) <= 0.5


@pytest.mark.parametrize("weights", [(1.0, 1.0, 1.0), (2.0, 0.5, 1.0), (0.0, 3.0, 0.1)])
def test_summed_uncommon_equals_the_weighted_sum_of_the_maps(rng, weights):
    # H and S share one lookup on a byte holding both labels; it must add up like three.
    params = DEFAULT.replace(plane_weights=weights)
    segs = []
    for k in (8, 5, 3):
        areas = sorted(rng.integers(1, 5000, k).tolist(), reverse=True)
        classes = tuple(PlaneClass(10 * i, 3, 1.0, a) for i, a in enumerate(areas))
        labels = rng.integers(0, k + 1, (40, 60)).astype(np.uint8)
        segs.append(Segmentation(labels, classes, np.zeros((256, 256), np.float32)))
    total, scale = summed_uncommon(tuple(segs), params)
    expected = sum(w * uncommon_map(s, params) for s, w in zip(segs, weights, strict=True))
    assert total.dtype == np.uint8
    # Each plane's table is rounded to 1 / scale, so the sum is within 1.5 of those steps.
    assert np.abs(total / scale - expected).max() <= 1.5 / scale + 1e-6
