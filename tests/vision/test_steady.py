"""The colour's pre-smoothing set from the view itself: more on a colourful view's H and S,
none beyond ``presmooth`` on a grey one; and the real bench's per-class groups of the
magnetic tiles."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from bench.real import run
from cyborg.daemon.sim.camera_effects import jpeg_round_trip
from cyborg.daemon.vision.hsi import colour_contrast
from cyborg.daemon.vision.params import DEFAULT, VisionParams
from cyborg.daemon.vision.pipeline import analyze

STEADY = DEFAULT.replace(presmooth_colour=2.0)
"""``default`` with the colour's pre-smoothing set from the view (an opt-in setting,
measured in ``bench.real``)."""


def _scene(colour: bool) -> np.ndarray:
    """A smooth field with a few blobs: green plants on brown soil, or the same in grey."""
    yy, xx = np.mgrid[0:180, 0:240].astype(np.float32)
    soil = np.stack([100 + 0.1 * xx, 115 + 0.05 * yy, 130 + 0.1 * yy], axis=2)
    img = soil.copy()
    for cy, cx, r in ((50, 60, 14), (120, 170, 18), (140, 50, 10)):
        img[(yy - cy) ** 2 + (xx - cx) ** 2 < r * r] = (40, 150, 50)
    img = np.clip(img, 0, 255).astype(np.uint8)
    if not colour:
        img = np.repeat(img.mean(axis=2, keepdims=True), 3, axis=2).astype(np.uint8)
    return img


def _noisy(img: np.ndarray, sigma: float, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.clip(np.rint(img + rng.normal(0.0, sigma, img.shape)), 0, 255).astype(np.uint8)


def test_colour_contrast_tells_a_colourful_view_from_a_grey_one() -> None:
    def contrast(img: np.ndarray) -> int:
        return colour_contrast(analyze(img, DEFAULT).hsi.s)

    grey, colour = _scene(colour=False), _scene(colour=True)
    assert contrast(_noisy(grey, 2.0)) < 20
    assert contrast(colour) > 60
    assert contrast(jpeg_round_trip(_noisy(colour, 2.0), 75)) > 60


def test_a_colourful_views_hue_is_smoothed_more_a_grey_ones_not() -> None:
    fixed = STEADY.replace(presmooth_colour=0.0)
    grey = _noisy(_scene(colour=False), 2.0)
    a, b = analyze(grey, STEADY).hsi, analyze(grey, fixed).hsi
    assert all(np.array_equal(p, q) for p, q in zip(a.planes, b.planes, strict=True))
    colour = _noisy(_scene(colour=True), 2.0)
    a, b = analyze(colour, STEADY).hsi, analyze(colour, fixed).hsi
    assert np.array_equal(a.i, b.i)  # brightness keeps its own smoothing
    assert not np.array_equal(a.s, b.s)
    assert float(cv2.Laplacian(a.s, cv2.CV_32F).std()) < float(cv2.Laplacian(b.s, cv2.CV_32F).std())


def test_a_negative_presmoothing_rate_is_refused() -> None:
    with pytest.raises(ValueError, match="presmooth_colour"):
        VisionParams(presmooth_colour=-1.0)


def test_real_bench_reports_magnetic_tile_classes(tmp_path: Path) -> None:
    """Each defect class is its own group, so a class behind a baseline shows."""
    folder = tmp_path / "magnetic_tile"
    (folder / "images").mkdir(parents=True)
    (folder / "masks").mkdir()
    rows = ["name\ttag\tmask_share"]
    for k, tag in enumerate(("MT_Break", "MT_Break", "MT_Crack")):
        img = np.full((60, 80), 120, np.uint8)
        mask = np.zeros_like(img)
        img[20 + 5 * k : 30 + 5 * k, 30:40] = 40
        mask[20 + 5 * k : 30 + 5 * k, 30:40] = 255
        cv2.imwrite(str(folder / "images" / f"{k}.png"), img)
        cv2.imwrite(str(folder / "masks" / f"{k}.png"), mask)
        rows.append(f"{k}.png\t{tag}\t0.02")
    (folder / "manifest.tsv").write_text("\n".join(rows) + "\n")
    groups = run(tmp_path, methods=["random"])["groups"]
    assert groups["magnetic_tile/MT_Break"]["n"] == 2
    assert groups["magnetic_tile/MT_Crack"]["n"] == 1
