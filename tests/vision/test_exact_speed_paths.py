"""The per-call savings of ``default`` compute what the expressions they replace computed, bit
for bit, on seeded scenes: the bar contrast's compiled max/min passes and scaling, the log
lookups, texture's moments and centring, the explanation's histograms and texture rank; and
an analysis process reuses the pages it frees."""

from __future__ import annotations

import math
import subprocess
import sys

import cv2
import numpy as np
import pytest

from cyborg.daemon.sim.scene import outcrop_scene
from cyborg.daemon.vision import explain, lines, shadow, texture
from cyborg.daemon.vision.exact import exact
from cyborg.daemon.vision.hsi import rgb_to_hsi
from cyborg.daemon.vision.interest import InterestPoint
from cyborg.daemon.vision.order import median
from cyborg.daemon.vision.params import DEFAULT


def _images() -> list[np.ndarray]:
    """Outcrops of a few sizes (odd sides too) and uniform noise, from seeded generators."""
    rng = np.random.default_rng(12)
    scenes = [outcrop_scene(seed, (96 + 7 * seed, 150 - 9 * seed)).image for seed in range(4)]
    noise = [
        rng.integers(0, 256, (int(rng.integers(9, 80)), int(rng.integers(9, 80)), 3), np.uint8)
        for _ in range(4)
    ]
    return scenes + noise


def _same(a: object, b: object) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)


def reference_line_rarity(bgr: np.ndarray, width: float, length: float) -> np.ndarray:
    """``lines.line_rarity`` as whole-array OpenCV and numpy expressions."""
    grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY).astype(np.float32)
    plane = cv2.log(grey * np.float32(1.0 / 255.0) + np.float32(lines._FLOOR))
    rows, cols = plane.shape
    side = 2.0 * width + 1.0
    e = math.ceil(side)
    smooth = cv2.GaussianBlur(plane, (0, 0), 0.6 * width)
    padded = cv2.copyMakeBorder(smooth, e, e, e, e, cv2.BORDER_REPLICATE)
    bright = np.zeros((rows, cols), np.float32)
    dark = np.zeros((rows, cols), np.float32)
    for i in range(lines._ORIENTATIONS):
        theta = math.pi * i / lines._ORIENTATIONS
        mean = cv2.filter2D(padded, -1, lines._segment_kernel(i, length))
        dy, dx = round(side * math.cos(theta)), round(-side * math.sin(theta))
        centre = mean[e : e + rows, e : e + cols]
        one = mean[e - dy : e - dy + rows, e - dx : e - dx + cols]
        other = mean[e + dy : e + dy + rows, e + dx : e + dx + cols]
        cv2.max(bright, cv2.subtract(centre, cv2.max(one, other)), dst=bright)
        cv2.max(dark, cv2.subtract(cv2.min(one, other), centre), dst=dark)
    bar = np.where(bright >= dark, bright, -dark)
    step = max(1, math.isqrt(bar.size // lines._SAMPLE))
    sample = np.abs(bar[::step, ::step])
    centre = float(median(sample))
    scale = max(1.4826 * float(median(np.abs(sample - centre))), lines._MAD_FLOOR)
    strength = np.maximum(np.abs(bar) - np.float32(centre), np.float32(0.0))
    return np.copysign(strength * np.float32(1.0 / scale), bar)


def test_line_rarity_matches_the_array_expressions() -> None:
    for img in _images():
        for width, length in ((DEFAULT.line_width, DEFAULT.line_length), (1.5, 6.0)):
            params = DEFAULT.replace(line_width=width, line_length=length)
            expected = exact(reference_line_rarity)(img, width, length)
            assert _same(lines.line_rarity(img, params), expected)


def test_the_shadow_gates_log_lookup_is_the_logarithm() -> None:
    for img in _images():
        expected = exact(cv2.log)(img.astype(np.float32) + np.float32(shadow._OFFSET))
        assert _same(cv2.LUT(img, shadow._LOGS), expected)


def test_texture_moments_and_centring_are_numpys() -> None:
    rng = np.random.default_rng(13)
    for t in range(40):
        n = int(rng.integers(40, 20000))
        sample = rng.normal(size=(n, 5)) * rng.uniform(1e-3, 10, 5) + rng.uniform(-5, 5, 5)
        if t % 2:
            sample = sample[rng.random(n) < 0.75]  # as a concentration step's kept rows
        mean, cov = texture._moments(sample)
        assert _same(mean, sample.mean(0))
        assert _same(cov, np.cov(sample, rowvar=False))
        centre = mean.astype(np.float32)
        for rows in (sample, sample.astype(np.float32)):
            expected = (rows - centre).astype(np.float32, copy=False)
            assert _same(texture._centred(rows, centre), expected)


def reference_typical(h: np.ndarray, s: np.ndarray, i: np.ndarray) -> tuple[str, float]:
    """``explain._typical``'s colour word and the I median, by ``np.bincount``."""

    def middle(values: np.ndarray) -> float:
        counts = np.bincount(values.ravel(), minlength=256)
        return float(np.searchsorted(np.cumsum(counts), (values.size + 1) / 2))

    weight = np.bincount(h.ravel(), weights=s.ravel().astype(np.float64) + 1e-9, minlength=256)
    mean = math.atan2(
        float(weight @ np.sin(explain._ANGLES)), float(weight @ np.cos(explain._ANGLES))
    )
    return explain.colour_name(math.degrees(mean) % 360, middle(s), middle(i)), middle(i)


def test_the_explanations_histograms_are_bincounts() -> None:
    rng = np.random.default_rng(14)
    for img in _images():
        hsi = rgb_to_hsi(img)
        whole, tones = explain._typical(*hsi.planes)
        assert _same(tones, np.bincount(hsi.i.ravel(), minlength=256))
        assert whole == reference_typical(*hsi.planes)[0]
        for _ in range(5):
            pick = rng.random(hsi.i.shape) < rng.uniform(0.001, 0.2)
            h, s, i = (plane[pick] for plane in hsi.planes)
            if h.size:
                here, tones = explain._typical(h, s, i)
                assert (here, explain._middle(tones)) == reference_typical(h, s, i)


def test_the_texture_rank_is_the_sorted_samples() -> None:
    rng = np.random.default_rng(15)
    for img in _images()[:4]:
        rare = texture.texture_rarity(img, DEFAULT)
        sample = rare[::2, ::2]
        ranked = np.sort(sample, axis=None)
        for _ in range(10):
            y, x = rng.uniform(0, rare.shape[0] - 1), rng.uniform(0, rare.shape[1] - 1)
            point = InterestPoint(1, x, y, 1.0, 5.0)
            entry = explain._texture_entry(rare, point, 5.0, sample)
            box, kernel = explain._gaussian_window(point, 5.0, rare.shape)
            rarity = float((rare[box] * kernel).sum())
            expected = float(np.searchsorted(ranked, rarity)) / len(ranked)
            assert entry["rarer_than"] == round(expected, 4)


_FAULTS = """
import resource
from cyborg.daemon.vision.threads import single_thread
single_thread()
from cyborg.daemon.sim.scene import outcrop_scene
from cyborg.daemon.vision.params import DEFAULT
from cyborg.daemon.vision.pipeline import analyze
image = outcrop_scene(1, (256, 384)).image
for _ in range(3):
    analyze(image, DEFAULT)  # the first images: the heap grows to what one needs
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
analyze(image, DEFAULT)
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_an_analysis_process_reuses_the_pages_it_frees() -> None:
    """One more image analysed: ~1200 fresh pages without the setting, a few with it."""
    run = [sys.executable, "-c", _FAULTS]
    out = subprocess.run(run, check=False, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert int(out.stdout) < 100, out.stdout
