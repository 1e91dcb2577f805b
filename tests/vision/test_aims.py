"""Aims of study: the kind asked for comes first, a kind set aside comes last but is still
reported, and ``any`` is the science's own ranking, untouched."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from cyborg.daemon.vision.aims import kind_maps
from cyborg.daemon.vision.hsi import rgb_to_hsi
from cyborg.daemon.vision.interest import InterestPoint
from cyborg.daemon.vision.job import analyze_image
from cyborg.daemon.vision.lines import line_rarity
from cyborg.daemon.vision.params import DEFAULT, PROFILES, with_settings
from cyborg.daemon.vision.peaks import find_points, mark_background

PLANT, STAIN, LICHEN = (200, 60), (70, 120), (250, 140)
"""(x, y) of each object on :func:`_outcrop`."""


def _outcrop(seed: int = 3) -> np.ndarray:
    """Pale buff rock, 180x300, with a small green plant, a large dark wet stain, a white
    vein and an orange lichen, and sensor noise: BGR uint8."""
    rng = np.random.default_rng(seed)
    img = np.full((180, 300, 3), (150, 170, 190), np.float64)
    img *= 1 + 0.04 * cv2.GaussianBlur(rng.standard_normal((180, 300)), (0, 0), 2.0)[..., None]
    cv2.circle(img, PLANT, 5, (50, 150, 70), -1)
    stain = cv2.circle(np.zeros((180, 300), np.uint8), STAIN, 14, 1, -1).astype(bool)
    img[stain] *= 0.6
    cv2.line(img, (120, 120), (180, 180), (235, 235, 235), 2)
    cv2.circle(img, LICHEN, 6, (30, 140, 230), -1)
    img += rng.normal(0.0, 2.5, img.shape)
    return np.clip(img, 0, 255).astype(np.uint8)


def _near(point: InterestPoint, xy: tuple[int, int], reach: float = 8.0) -> bool:
    return math.hypot(point.x - xy[0], point.y - xy[1]) <= reach


def _on(points: list[InterestPoint], xy: tuple[int, int]) -> list[int]:
    """Ranks of the points on the object at ``xy``."""
    return [p.rank for p in points if _near(p, xy)]


def test_aim_is_a_setting_in_canonical_form() -> None:
    assert with_settings(DEFAULT, ["aim=No-Sky + dark"]).aim == "dark+no-sky"
    assert all(p.aim == "any" for p in PROFILES.values())
    with pytest.raises(ValueError, match="aim 'wet'"):
        with_settings(DEFAULT, ["aim=wet"])
    with pytest.raises(ValueError, match="one kind at most"):
        DEFAULT.replace(aim="dark+bright")


@pytest.mark.parametrize("profile", ["default", "paper"])
def test_any_is_the_science_untouched(profile: str) -> None:
    params = PROFILES[profile]
    _, res = analyze_image(_outcrop(), params)
    assert res.points == mark_background(res.interest, find_points(res.interest, params))
    assert not any(e["plane"] == "aim" for expl in res.explanations for e in expl)


def test_without_an_aim_the_plant_is_first() -> None:
    """The case an aim is for: the plant is the most uncommon thing in view."""
    _, res = analyze_image(_outcrop(), DEFAULT)
    assert _on(res.points, PLANT)[:1] == [1]


def test_dark_aim_puts_the_stain_first_and_keeps_the_plant() -> None:
    _, res = analyze_image(_outcrop(), DEFAULT.replace(aim="dark"))
    assert _on(res.points, STAIN) == [1]
    assert _on(res.points, PLANT), "the science's own best point is still reported"
    assert [p.rank for p in res.points] == list(range(1, len(res.points) + 1))
    assert res.explanations[0][-1] == {
        "plane": "aim",
        "aim": "dark",
        "kind": "dark",
        "match": "sought",
    }
    assert res.descriptions[0].endswith("; what the aim seeks")


def _on_vein(point: InterestPoint, reach: float = 6.0) -> bool:
    """Within ``reach`` of the vein of :func:`_outcrop`, (120, 120) to (180, 180)."""
    t = min(1.0, max(0.0, ((point.x - 120) + (point.y - 120)) / 120))
    return math.hypot(point.x - 120 - 60 * t, point.y - 120 - 60 * t) <= reach


def test_a_kind_aim_puts_its_kind_first() -> None:
    _, res = analyze_image(_outcrop(), DEFAULT.replace(aim="bright"))
    assert res.points[0].target and _on_vein(res.points[0])
    _, res = analyze_image(_outcrop(), DEFAULT.replace(aim="colour"))
    assert res.points[0].target and _near(res.points[0], LICHEN, 12.0)


def test_no_vegetation_ranks_the_plant_after_but_lists_it() -> None:
    _, res = analyze_image(_outcrop(), DEFAULT.replace(aim="no-vegetation"))
    ranks = _on(res.points, PLANT)
    assert ranks and ranks[0] != 1
    k = ranks[0] - 1
    assert res.points[k].target
    assert res.explanations[k][-1]["match"] == "set aside"
    assert res.descriptions[k].endswith("; set aside by the aim (vegetation)")


def test_no_sky_ranks_the_sky_last_where_it_was_all_the_science_saw() -> None:
    """``paper`` (no discount on bands along the frame) gives all three points to a sky strip
    over the outcrop; with ``no-sky`` the rock's targets come first and the sky's best point,
    the science's own best, is still reported, last."""
    image = _outcrop()
    rng = np.random.default_rng(0)
    image[:30] = np.clip(rng.normal((235, 200, 160), 2.0, (30, 300, 3)), 0, 255)
    _, plain = analyze_image(image, PROFILES["paper"])
    assert all(p.y < 30 for p in plain.points)
    _, res = analyze_image(image, PROFILES["paper"].replace(aim="no-sky"))
    assert [p.y < 30 for p in res.points] == [False] * (len(res.points) - 1) + [True]
    assert (res.points[-1].x, res.points[-1].y) == (plain.points[0].x, plain.points[0].y)
    assert res.explanations[-1][-1]["kind"] == "sky"
    assert res.descriptions[-1].endswith("; set aside by the aim (sky)")


def _beds(seed: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grey-buff beds under a sky, 160x240: a white grainy bed across the view, a dark grey
    bed below it, a wet stain on the lower bed and a thin calcite vein crossing it; BGR
    uint8 and the stain's and the vein's masks."""
    rng = np.random.default_rng(seed)
    img = np.empty((160, 240, 3), np.float64)
    img[:] = (140, 150, 160)
    img[:30] = (225, 200, 170)  # a clear sky
    img[60:80] = (215, 215, 215)  # the white bed, grainy
    img[60:80] += rng.normal(0.0, 4.0, (20, 240, 1))
    img[80:100] = (100, 105, 110)  # a dark grey bed
    stain = cv2.circle(np.zeros((160, 240), np.uint8), (60, 130), 13, 1, -1).astype(bool)
    img[stain] = (45, 60, 80)  # wet: darker, its colour deeper
    vein = cv2.line(np.zeros((160, 240), np.uint8), (150, 105), (200, 150), 1, 2).astype(bool)
    img[vein] = (205, 205, 205)
    img += rng.normal(0.0, 2.0, img.shape)
    return np.clip(img, 0, 255).astype(np.uint8), stain, vein


def _near_mask(mask: np.ndarray, reach: int = 4) -> np.ndarray:
    size = 2 * reach + 1
    return cv2.dilate(mask.astype(np.uint8), np.ones((size, size), np.uint8)).astype(bool)


def test_tone_kinds_are_the_stain_and_the_vein_not_beds_edges_grain_or_skyline() -> None:
    """A bed's edge is a step, not a patch; a white bed's grain is no crust; the rock under
    the skyline is not dark for being under the sky; a vein is a thin bright line."""
    img, stain, vein = _beds()
    hsi = rgb_to_hsi(img)
    maps = kind_maps(img, hsi, bars=line_rarity(img, DEFAULT))
    dark, bright = maps["dark"] >= 0.5, maps["bright"] >= 0.5
    assert dark[stain].mean() > 0.3
    assert not (dark & ~_near_mask(stain)).any()
    assert bright[vein].mean() > 0.5
    assert not (bright & ~_near_mask(vein)).any()
    assert not (maps["dark"] >= 0.5)[vein].any(), "no dark target where a vein crosses"


@pytest.mark.parametrize(("aim", "mask"), [("dark", 1), ("bright", 2)])
def test_tone_aims_put_their_kind_first_among_beds(aim: str, mask: int) -> None:
    img, *masks = _beds()
    _, res = analyze_image(img, DEFAULT.replace(aim=aim))
    best = res.points[0]
    assert _near_mask(masks[mask - 1], 6)[round(best.y), round(best.x)]


def test_nothing_of_the_kind_in_view_leaves_the_science_order() -> None:
    """Plain rock with a plant and a lichen: nothing bright, so ``bright`` reports what
    ``any`` does, in its order."""
    rng = np.random.default_rng(2)
    img = np.full((120, 160, 3), (120, 140, 160), np.float64)
    cv2.circle(img, (40, 60), 5, (50, 150, 70), -1)
    cv2.circle(img, (120, 50), 6, (30, 140, 230), -1)
    img = np.clip(img + rng.normal(0.0, 2.5, img.shape), 0, 255).astype(np.uint8)
    _, plain = analyze_image(img, DEFAULT)
    _, res = analyze_image(img, DEFAULT.replace(aim="bright"))
    targets = [(p.x, p.y) for p in plain.points if p.target]
    assert len(targets) == 2
    assert [(p.x, p.y) for p in res.points[:2]] == targets


def test_a_vein_runs_on_a_curl_of_grain_does_not() -> None:
    """A short curled bright run beside a long vein is the rock's grain, not a second vein:
    the vein is bright, the curl is not."""
    img, _, vein = _beds()
    curl = cv2.ellipse(np.zeros(vein.shape, np.uint8), (60, 45), (6, 6), 0, 0, 270, 1, 2)
    img[curl.astype(bool)] = (205, 205, 205)
    bright = kind_maps(img, rgb_to_hsi(img), bars=line_rarity(img, DEFAULT))["bright"] >= 0.5
    assert bright[vein].mean() > 0.5
    assert not bright[_near_mask(curl.astype(bool))].any()


def _bright_and_dark(img: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    maps = kind_maps(img, rgb_to_hsi(img), bars=line_rarity(img, DEFAULT))
    return maps["bright"], maps["dark"]


def _grey(rows: int, cols: int, seed: int) -> np.ndarray:
    """Flat grey rock with sensor noise: float BGR."""
    rng = np.random.default_rng(seed)
    img = np.full((rows, cols, 3), 130.0)
    return img + rng.normal(0.0, 2.0, img.shape)


def test_a_vein_across_the_rock_outweighs_a_bright_line_along_a_contact() -> None:
    """A bed's lit rim is a thin bright line too, but with a darker bed on one side all along
    it: still bright (a vein may follow a bedding plane), after a vein across the rock."""
    img = _grey(160, 240, 7)
    img[80:] -= 40  # a darker bed below a contact
    rim = cv2.line(np.zeros((160, 240), np.uint8), (20, 79), (140, 79), 1, 2).astype(bool)
    img[rim] = 160
    vein = cv2.line(np.zeros((160, 240), np.uint8), (150, 10), (220, 60), 1, 2).astype(bool)
    img[vein] = 160
    bright, _ = _bright_and_dark(np.clip(img, 0, 255).astype(np.uint8))
    assert bright[vein].mean() > 0.8
    assert bright[rim].max() <= 0.5


def test_a_sliver_along_the_beds_is_no_stain() -> None:
    """A long thin dark piece lying along the bedding is a thin bed's piece or a ledge's
    shadow; a round stain as dark is a dark target."""
    img = _grey(180, 240, 8)
    for top in range(0, 180, 30):
        img[top : top + 15] += 12  # beds across the view
    stain = cv2.circle(np.zeros((180, 240), np.uint8), (60, 100), 12, 1, -1).astype(bool)
    img[stain] *= 0.65
    img[97:104, 148:182] *= 0.65  # the sliver, along the beds
    _, dark = _bright_and_dark(np.clip(img, 0, 255).astype(np.uint8))
    assert (dark[stain] >= 0.5).mean() > 0.3
    assert not (dark[95:106, 145:185] >= 0.5).any()
