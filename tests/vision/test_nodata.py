"""A no-data fill (the black beyond a mosaic's or a panorama's edge) is not image: never a
class, never a point, its edge no target; a real dark shadow is still image."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from cyborg.daemon.sim.camera_effects import jpeg_round_trip
from cyborg.daemon.vision.contract import AnalysisJob
from cyborg.daemon.vision.job import analyze_image
from cyborg.daemon.vision.nodata import MARGIN, no_data_mask
from cyborg.daemon.vision.params import PROFILES

PLANT = (205, 150)
"""(x, y) of the green plant in :func:`_rock`."""


def _rock(seed: int = 5) -> np.ndarray:
    """Buff rock with mottling and sensor noise, a green plant at :data:`PLANT`, (240, 320, 3)."""
    rng = np.random.default_rng(seed)
    mottle = cv2.resize(rng.normal(0.0, 6.0, (24, 32)), (320, 240), interpolation=cv2.INTER_CUBIC)
    rock = np.full((240, 320, 3), (110, 140, 170), np.float64) + mottle[..., None]
    rock += rng.normal(0.0, 2.0, rock.shape)
    image = np.clip(np.rint(rock), 0, 255).astype(np.uint8)
    cv2.circle(image, PLANT, 9, (40, 150, 50), -1)
    return image


def _tile(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The rock as a tile at a mosaic's corner: black beyond its left and top edges, then a
    look through the camera (noise sigma 2 everywhere, the fill too, and a JPEG at 75), so
    the fill is near black, not exactly 0. Returns (image, fill)."""
    image = _rock()
    fill = np.zeros(image.shape[:2], bool)
    fill[:, :90] = True
    fill[:60] = True
    image[fill] = 0
    rng = np.random.default_rng(seed)
    noisy = np.clip(np.rint(image + rng.normal(0.0, 2.0, image.shape)), 0, 255).astype(np.uint8)
    return jpeg_round_trip(noisy, 75), fill


@pytest.mark.parametrize("profile", ["default", "uncommon", "paper"])
@pytest.mark.parametrize("seed", [1, 2])
def test_a_mosaic_fill_is_never_a_class_and_holds_no_point(profile: str, seed: int) -> None:
    image, fill = _tile(seed)
    _, res = analyze_image(image, PROFILES[profile])
    for seg in res.segmentations:  # unsegmented there, and black is no class anywhere
        assert not seg.labels[fill].any()
    assert all(seg.original_value(c.center) > 20 for c in res.segmentations[2].classes)
    away = cv2.distanceTransform((~fill).view(np.uint8), cv2.DIST_L2, 5)
    for p in res.points:  # not on the fill, not on its edge
        assert away[round(p.y), round(p.x)] > MARGIN, p
    best = res.points[0]
    assert np.hypot(best.x - PLANT[0], best.y - PLANT[1]) < 12, best
    assert any(note.startswith("no-data fill") for note in res.notes)


def test_the_fill_is_found_through_noise_and_jpeg_and_only_the_fill() -> None:
    image, fill = _tile(3)
    assert image[fill].max() > 0  # near black, not pure
    found = no_data_mask(image)
    assert found is not None
    # All of the fill but the JPEG's ringing right at its edge, and nothing of the rock.
    assert found[fill].mean() > 0.97 and not found[~fill].any()


def test_a_dark_shadow_is_image() -> None:
    """A deep shadow inside the view (not pure black, not touching the frame) and a rover's
    near-black shadow running into the frame's edge (mean 5: a Navcam's deepest) are
    segmented and scored like any rock."""
    image = _rock()
    rng = np.random.default_rng(9)
    shadow = np.zeros(image.shape[:2], bool)
    cv2.ellipse(shadow.view(np.uint8), (90, 80), (40, 18), 20, 0, 360, 1, -1)
    image[shadow] = np.clip(rng.normal(14.0, 3.0, (int(shadow.sum()), 3)), 0, 255).astype(np.uint8)
    rover = np.zeros(image.shape[:2], bool)
    rover[200:, 20:110] = True
    image[rover] = np.clip(rng.normal(5.0, 2.0, (int(rover.sum()), 3)), 0, 255).astype(np.uint8)
    assert no_data_mask(image) is None
    _, res = analyze_image(image, PROFILES["default"])
    intensity = res.segmentations[2]
    inner = cv2.erode(shadow.view(np.uint8), np.ones((5, 5), np.uint8)).view(bool)
    assert (intensity.labels[inner] > 0).mean() > 0.9  # the shadow is a class of its own
    assert not any(note.startswith("no-data fill") for note in res.notes)


def test_paper_says_why_it_has_no_point(tmp_path: Path) -> None:
    """Plain rock: one class in every plane, so ``paper`` has no point and result.json and
    the overlay say why instead of returning silence."""
    rng = np.random.default_rng(3)
    rock = np.full((120, 160, 3), (120, 150, 170), np.float64) + rng.normal(0.0, 3.0, (120, 160, 3))
    image = np.clip(rock, 0, 255).astype(np.uint8)
    result = AnalysisJob(str(tmp_path), image, "paper", "rock.png").run()
    doc = json.loads((tmp_path / "result.json").read_text())
    assert doc["points"] == [] and doc["notes"] == list(result.notes)
    assert doc["notes"] == ["one class in H, S and I: nothing is uncommon at this resolution"]
    overlay = cv2.imread(str(tmp_path / result.products["overlay"]))
    assert (overlay != image).any()  # the note is written on it
