import math

import cv2
import numpy as np
import pytest

from bench.heldout import REGIMES as HELD_OUT
from cyborg.daemon.sim.regimes import REGIMES as OURS
from cyborg.daemon.vision.cooccurrence import PlaneClass, Segmentation
from cyborg.daemon.vision.explain import describe
from cyborg.daemon.vision.imageio import as_bgr8
from cyborg.daemon.vision.interest import (
    InterestMap,
    _roundness,
    interest_map,
    summed_uncommon,
)
from cyborg.daemon.vision.params import DEFAULT, PAPER
from cyborg.daemon.vision.peaks import find_points
from cyborg.daemon.vision.pipeline import analyze
from cyborg.daemon.vision.uncommon import uncommon_map


def rock_with_blob(rng, size=12, blob_colour=(40, 160, 40)):
    """Two noisy beds and a green blob of side ``size`` centred on (x, y) = (35.5, 85.5)."""
    img = np.empty((120, 160, 3), np.float64)
    img[:60] = (60, 110, 160)
    img[60:] = (120, 150, 170)
    img += rng.normal(0, 3, img.shape)
    lo, hi = 86 - size // 2, 86 + size // 2
    img[lo:hi, 36 - size // 2 : 36 + size // 2] = blob_colour
    return np.clip(img, 0, 255).astype(np.uint8)


# The blob is matched to each profile's blur scale B (FWHM 10 px for paper, 2 px for default).
@pytest.mark.parametrize(("params", "size"), [(PAPER, 16), (DEFAULT, 12)])
def test_odd_coloured_blob_is_the_top_point(rng, params, size):
    res = analyze(rock_with_blob(rng, size), params)
    top = res.points[0]
    assert abs(top.x - 35.5) < 4 and abs(top.y - 85.5) < 4
    assert [p.rank for p in res.points] == list(range(1, len(res.points) + 1))
    scores = [p.score for p in res.points]
    assert scores == sorted(scores, reverse=True)
    planes = [e["plane"] for e in res.explanations[0]]
    extra = ["texture"] * bool(params.texture_weight) + ["shade"] * bool(params.shadow_gate)
    extra += ["layer"] * bool(params.layers) + ["line"] * bool(params.line_weight)
    assert planes == ["H", "S", "I", *extra]
    contributions = {e["plane"]: e["contribution"] for e in res.explanations[0][:3]}
    assert max(contributions.values()) > 0


def test_decimated_blur_matches_exact_blur(rng):
    params = PAPER.replace(blur_mode="sigma")
    res = analyze(rock_with_blob(rng, 24), params)
    fast = interest_map(res.segmentations, params)
    exact = interest_map(res.segmentations, params.replace(exact_blur=True))
    assert fast.factor == 4 and exact.factor == 1
    err = np.abs(fast.full() - exact.full())
    assert err.max() < 0.075 * exact.grid.max()  # worst in the corners (zero padding)
    p_fast, p_exact = find_points(fast, params)[0], find_points(exact, params)[0]
    assert abs(p_fast.x - p_exact.x) < 1.5 and abs(p_fast.y - p_exact.y) < 1.5


def test_points_respect_separation(rng):
    img = rng.integers(0, 256, (100, 100, 3), dtype=np.uint8)
    pts = analyze(img, PAPER.replace(top_n=10)).points
    for i, a in enumerate(pts):
        for b in pts[i + 1 :]:
            assert np.hypot(a.x - b.x, a.y - b.y) >= PAPER.separation(img.shape[:2]) - 2


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
    assert res.descriptions[0].startswith("bright white patch")


def ledge_and_plant(rng):
    """A bluish ledge shadow across the frame (rare in H, S and I) and a plant of the
    rock's brightness, rare mostly in H."""
    img = np.empty((120, 200, 3), np.float64)
    img[:] = (60, 110, 160)
    img += rng.normal(0, 3, img.shape)
    img[30:38] = (70, 40, 30)  # a ledge shadow, 8 px high, across the frame
    img[80:90, 95:105] = (60, 160, 110)  # a plant, 10 px across
    return np.clip(img, 0, 255).astype(np.uint8)


def test_isotropy_prefers_a_compact_spot_to_a_ledge_shadow(rng):
    img = ledge_and_plant(rng)
    ungated = DEFAULT.replace(shadow_gate=0.0)  # shape alone, not colour (``test_shadow``)
    plain = analyze(img, ungated.replace(isotropy=0.0))
    assert abs(plain.points[0].y - 34) < 5, "without the shape term the shadow wins"
    assert abs(analyze(img, ungated).points[0].y - 84.5) < 3
    res = analyze(img, DEFAULT)
    top = res.points[0]
    assert abs(top.x - 99.5) < 3 and abs(top.y - 84.5) < 3
    assert "green" in res.descriptions[0]
    exact = interest_map(res.segmentations, DEFAULT.replace(exact_blur=True))
    assert abs(find_points(exact, DEFAULT)[0].x - top.x) < 1.5


def test_three_points_are_three_targets_of_any_size(rng):
    """A big lichen patch (with texture that makes several peaks inside it) and two small
    spots: the valley rule gives one point per target, whatever its size."""
    img = np.empty((200, 260, 3), np.float64)
    img[:] = (110, 140, 170)
    img += rng.normal(0, 3, img.shape)
    yy, xx = np.mgrid[:200, :260]
    lichen = (yy - 70) ** 2 + (xx - 80) ** 2 < 40**2
    img[lichen] = (40, 160, 150)
    img[lichen] += rng.normal(0, 12, (int(lichen.sum()), 3))
    img[150:158, 200:208] = (40, 40, 190)  # a red spot
    img[40:47, 210:217] = (235, 235, 235)  # a white nodule
    img = np.clip(img, 0, 255).astype(np.uint8)
    res = analyze(img, DEFAULT)
    assert len(res.points) == 3
    found = set()
    for p in res.points:
        if lichen[round(p.y), round(p.x)]:
            found.add("lichen")
        elif abs(p.x - 203.5) < 6 and abs(p.y - 153.5) < 6:
            found.add("red")
        elif abs(p.x - 213) < 6 and abs(p.y - 43) < 6:
            found.add("white")
    assert found == {"lichen", "red", "white"}
    big = next(p for p in res.points if lichen[round(p.y), round(p.x)])
    assert big.radius > 20  # the patch's own size, not the blur


def test_thin_bright_vein_in_dark_rock_is_found(rng):
    img = np.empty((216, 288, 3), np.float64)
    img[:] = (52, 62, 118)  # dark red mudstone
    img += rng.normal(0, 3, img.shape)
    for x in range(60, 200):  # a white vein 2 px wide, slightly curved
        y = round(110 + 12 * np.sin(x / 40.0))
        img[y : y + 2, x] = (232, 236, 238)
    img = np.clip(img, 0, 255).astype(np.uint8)
    res = analyze(img, DEFAULT)
    top = res.points[0]
    assert 55 <= top.x <= 205 and abs(top.y - (110 + 12 * np.sin(top.x / 40.0))) < 8


def test_a_band_is_discounted_below_a_compact_patch() -> None:
    """A bed of rare colour across the frame, 20 px thick, outscores a round patch by a
    quarter; as a band (aspect 12 : 1, wider than the blur) it comes second. A line the
    blur made (a vein, 2 px) keeps its height."""
    grid = np.zeros((120, 240), np.float32)
    grid[70:90, :] = 1.0
    yy, xx = np.mgrid[:120, :240]
    grid[(yy - 30) ** 2 + (xx - 120) ** 2 < 15**2] = 0.8
    imap = InterestMap(cv2.GaussianBlur(grid, (0, 0), 2.0), 1, grid.shape)
    params = DEFAULT.replace(blur_fraction=0.0, blur=2.0, blur_mode="sigma", top_n=2)

    def where(point) -> str:
        return "band" if 70 <= point.y < 90 else "patch" if abs(point.y - 30) < 3 else "?"

    assert [where(p) for p in find_points(imap, params.replace(bands=0.0))] == ["band", "patch"]
    points = find_points(imap, params)
    assert [where(p) for p in points] == ["patch", "band"]
    assert points[1].score < 0.8 * 0.99
    vein = np.zeros((120, 240), np.float32)
    vein[60:62, 20:220] = 1.0
    imap = InterestMap(cv2.GaussianBlur(vein, (0, 0), 2.0), 1, vein.shape)
    line = find_points(imap, params)[0]
    assert (
        59 <= line.y <= 62 and line.score == find_points(imap, params.replace(bands=0.0))[0].score
    )


def test_a_sliver_along_the_frame_is_discounted() -> None:
    """A rare bed the frame cuts to a 6 px sliver along the top outscores a patch inside the
    view; discounted by the share of it that hugs the frame, it comes second."""
    grid = np.zeros((120, 240), np.float32)
    grid[:6, 40:200] = 1.0
    yy, xx = np.mgrid[:120, :240]
    grid[(yy - 70) ** 2 + (xx - 120) ** 2 < 10**2] = 0.8
    blurred = cv2.GaussianBlur(grid, (0, 0), 2.0, borderType=cv2.BORDER_CONSTANT)
    imap = InterestMap(blurred, 1, grid.shape)
    params = DEFAULT.replace(blur_fraction=0.0, blur=2.0, blur_mode="sigma", top_n=2)
    plain = find_points(imap, params.replace(frame=0.0))
    assert [p.y < 10 for p in plain] == [True, False]
    assert [p.y < 10 for p in find_points(imap, params)] == [False, True]


def test_peaks_come_in_the_order_a_full_sort_gives(rng):
    """Hundreds of peaks with many tied values: taking them lazily off a heap must not change
    the pick."""
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
    params = DEFAULT.replace(plane_weights=weights)
    segs = []
    for k in (8, 5, 3):
        areas = sorted(rng.integers(1, 5000, k).tolist(), reverse=True)
        classes = tuple(PlaneClass(10 * i, 3, 1.0, a) for i, a in enumerate(areas))
        labels = rng.integers(0, k + 1, (40, 60)).astype(np.uint8)
        values = rng.integers(0, 256, (40, 60)).astype(np.uint8)
        profile = rng.random(256) * 100
        segs.append(
            Segmentation(labels, classes, np.zeros((256, 256), np.float32), 0, values, profile)
        )
    total = summed_uncommon(tuple(segs), params)
    expected = sum(w * uncommon_map(s, params) for s, w in zip(segs, weights, strict=True))
    assert total.dtype == np.float32
    np.testing.assert_allclose(total, expected, rtol=1e-5, atol=1e-5)
    tails = [
        uncommon_map(s, params) - uncommon_map(s, params.replace(value_rarity=0)) for s in segs
    ]
    assert all(t.max() > 0 and (t[segs[i].labels == 0] == 0).all() for i, t in enumerate(tails))


def test_a_ring_is_aimed_at_its_centre() -> None:
    """A stain interesting at its rim, most on one side: the point is the ring's centre,
    not the high side (the next station must be aimed at the stain, not at its rim)."""
    yy, xx = np.mgrid[:120, :160].astype(np.float32)
    r = np.hypot(yy - 60, xx - 80)
    ring = np.exp(-((r - 20) ** 2) / 18.0) * (1.0 + 0.5 * (yy > 70))
    params = DEFAULT.replace(isotropy=0.0)
    (point,) = find_points(InterestMap(ring.astype(np.float32), 1, ring.shape), params)[:1]
    assert abs(point.x - 80) < 1.5 and abs(point.y - 60) < 1.5
    assert 20 < point.radius < 30


def test_a_rim_bright_on_one_side_is_aimed_at_its_centre() -> None:
    """A stain seen from 60 m whose rim is far more interesting on one side: above half the
    peak's height only that side's arc is left, and the ring closes lower down. The point
    is still the stain's centre (the next station is aimed there), not the bright arc."""
    yy, xx = np.mgrid[:120, :160].astype(np.float32)
    r = np.hypot(yy - 60, xx - 80)
    ring = np.exp(-((r - 20) ** 2) / 18.0) * (1.0 + 1.6 * np.clip((yy - 50) / 30, 0, 1))
    params = DEFAULT.replace(isotropy=0.0)
    (point,) = find_points(InterestMap(ring.astype(np.float32), 1, ring.shape), params)[:1]
    assert abs(point.x - 80) < 2 and abs(point.y - 60) < 2


def test_a_patch_lit_on_one_side_is_aimed_at_its_mass() -> None:
    """A filled patch (a stain interesting all over) whose top leans to one side, as where
    a bed contact crosses it: the point settles on the patch's centre, not on its top."""
    yy, xx = np.mgrid[:120, :160].astype(np.float32)
    blob = np.exp(-(np.hypot(yy - 60, xx - 80) ** 2) / (2 * 14.0**2))
    blob *= 1.0 + 0.5 * np.exp(-((xx - 92) ** 2 + (yy - 60) ** 2) / 40.0)
    params = DEFAULT.replace(isotropy=0.0)
    (point,) = find_points(InterestMap(blob.astype(np.float32), 1, blob.shape), params)[:1]
    assert abs(point.x - 80) < 3.5 and abs(point.y - 60) < 2  # the top's centre: 88


def test_a_wide_band_is_aimed_at_its_middle_whatever_the_noise() -> None:
    """A bed (a patch much longer than the point's radius) with a little texture on top:
    eight looks put the point within a few cells of one place, not wherever the noise puts
    the top (the top's centre wandered over 83 cells here)."""
    yy, xx = np.mgrid[:100, :200].astype(np.float32)
    band = np.exp(-((yy - 50) ** 2) / 128.0)
    band *= np.clip((xx - 20) / 10, 0, 1) * np.clip((180 - xx) / 10, 0, 1)
    params = DEFAULT.replace(isotropy=0.0, bands=0.0)
    xs = []
    for seed in range(8):
        noise = np.random.default_rng(seed).normal(0, 1, band.shape).astype(np.float32)
        noise = cv2.GaussianBlur(noise, (0, 0), 4)
        grid = (band * (1 + 0.05 * noise / noise.std())).astype(np.float32)
        xs.append(find_points(InterestMap(grid, 1, grid.shape), params)[0].x)
    assert np.ptp(xs) < 20 and abs(np.mean(xs) - 100) < 10


def test_a_patch_split_by_roundness_is_one_target() -> None:
    """A roundness ripple cuts a notch down one wide patch: two peaks on ``grid``, one patch
    on the map before roundness, so one point, not two on the same lichen."""
    yy, xx = np.mgrid[:120, :160].astype(np.float32)
    plain = np.exp(-((yy - 60) ** 2 + (xx - 80) ** 2) / (2 * 15.0**2)).astype(np.float32)
    grid = plain * (1.0 - 0.8 * np.exp(-((xx - 80) ** 2) / 18.0)).astype(np.float32)
    imap = InterestMap(grid, 1, grid.shape, plain=plain)
    points = find_points(imap, DEFAULT)
    assert sum(math.hypot(p.x - 80, p.y - 60) < 25 for p in points) == 1
    split = find_points(InterestMap(grid, 1, grid.shape), DEFAULT)  # judged on grid: two
    assert sum(math.hypot(p.x - 80, p.y - 60) < 25 for p in split) == 2


def test_a_flat_top_is_round_and_a_ridge_is_not() -> None:
    """On a wide flat patch the curvatures' ratio is noise; a flat top counts as round, so
    its ripples do not split it into peaks. A ridge (a ledge shadow's trace) stays unround."""
    rng = np.random.default_rng(0)
    yy, xx = np.mgrid[:160, :240].astype(np.float32)
    top = np.clip(40.0 - np.hypot(yy - 80, xx - 120), 0, 8) / 8.0  # flat inside r = 32
    top += rng.normal(0, 0.002, top.shape)
    iso = _roundness(cv2.GaussianBlur(top.astype(np.float32), (0, 0), 2.0), 2.0, 1.0)
    assert iso[70:91, 110:131].min() > 0.9
    ridge = np.exp(-((yy - 80) ** 2) / 50.0) * (np.abs(xx - 120) < 100)
    iso = _roundness(ridge.astype(np.float32), 2.0, 1.0)
    assert iso[80, 60:180].max() < 0.2


@pytest.mark.parametrize(("generator", "seed"), [(OURS, 1023), (HELD_OUT, 1019)])
def test_a_wide_patch_of_rare_colour_beats_rare_texture_along_the_beds(generator, seed):
    """A concretion of 9-13 % of the view among beds whose contacts and thin laminae are the
    rarest texture in view: texture marks only the patch's rim, so at one scale the beds
    win; blurred at its own scale (``wide_scale``) the patch is one high cap."""
    scene = generator["large"](seed)
    target = scene.target_labels > 0

    def on_target(params):
        top = analyze(scene.image, params).points[0]
        return bool(target[round(top.y), round(top.x)])

    assert not on_target(DEFAULT.replace(wide_scale=0.0)), "at one scale the beds win"
    assert on_target(DEFAULT)


def test_wide_scale_is_refused_between_0_and_1() -> None:
    with pytest.raises(ValueError, match="wide_scale"):
        DEFAULT.replace(wide_scale=0.5)
    with pytest.raises(ValueError, match="wide_scale"):
        DEFAULT.replace(wide_scale=math.inf)
