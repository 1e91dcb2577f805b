"""Baseline interest detectors scored beside the uncommon-map pipeline in the same run."""

from __future__ import annotations

import math

import cv2
import numpy as np

from cyborg.daemon.vision.interest import InterestMap, InterestPoint
from cyborg.daemon.vision.params import VisionParams
from cyborg.daemon.vision.peaks import find_points


def spectral_residual(bgr: np.ndarray, width: int = 64) -> np.ndarray:
    """Hou & Zhang (CVPR 2007) saliency: the spectral residual of the log amplitude.

    Computed on a grey image scaled to ``width`` columns, as in the paper, then brought back
    to the input size. Returns (M, N) float32.
    """
    rows, cols = bgr.shape[:2]
    grey = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY).astype(np.float32)
    w = min(width, cols)
    h = max(1, round(rows * w / cols))
    small = cv2.resize(grey, (w, h), interpolation=cv2.INTER_AREA)
    spectrum = np.fft.fft2(small)
    log_amp = np.log(np.abs(spectrum) + 1e-9)
    phase = np.angle(spectrum)
    residual = log_amp - cv2.blur(log_amp.astype(np.float32), (3, 3))
    sal = np.abs(np.fft.ifft2(np.exp(residual + 1j * phase))) ** 2
    sal = cv2.GaussianBlur(sal.astype(np.float32), (0, 0), 2.5)
    return cv2.resize(sal, (cols, rows), interpolation=cv2.INTER_LINEAR)


def rx_anomaly(bgr: np.ndarray) -> np.ndarray:
    """Reed-Xiaoli global anomaly detector: Mahalanobis distance of each pixel's colour.

    Returns (M, N) float32.
    """
    x = bgr.reshape(-1, 3).astype(np.float64)
    mean = x.mean(axis=0)
    cov = np.cov(x, rowvar=False) + np.eye(3) * 1e-3
    d = x - mean
    score = np.einsum("ij,jk,ik->i", d, np.linalg.inv(cov), d)
    return score.reshape(bgr.shape[:2]).astype(np.float32)


def colour_rarity(image: np.ndarray, bins: int = 8, grey_bins: int = 32) -> np.ndarray:
    """Global colour rarity: each pixel scores -log(share of the image in its colour bin).

    The simplest "uncommon colour" detector, a floor the uncommon map must beat: colour is
    quantised to ``bins`` levels per B, G, R channel (8 x 8 x 8 = 512 bins); a grey image
    (1 channel, or three equal channels) gets ``grey_bins`` intensity levels instead, since
    RGB binning would leave it only ``bins`` levels. No spatial context at all; blur the map
    (``points_from_map(..., blur=True)``) to turn rare pixels into rare regions.
    Returns (M, N) float32.

    Examples
    --------
    >>> img = np.full((10, 10), 100, np.uint8)
    >>> img[2, 3] = 250
    >>> rar = colour_rarity(img)
    >>> bool(rar[2, 3] > rar[0, 0]), round(float(rar[2, 3]), 2)
    (True, 4.61)
    """
    grey = image.ndim == 2 or image.shape[2] == 1
    if not grey and image.shape[2] >= 3:
        b, g, r = image[..., 0], image[..., 1], image[..., 2]
        grey = bool(np.array_equal(b, g) and np.array_equal(g, r))
    pixels = image.reshape((*image.shape[:2], -1))[..., :3].astype(np.int64)
    if grey:
        codes = pixels[..., 0] * grey_bins >> 8
        n_codes = grey_bins
    else:
        q = pixels * bins >> 8
        codes = (q[..., 0] * bins + q[..., 1]) * bins + q[..., 2]
        n_codes = bins**3
    counts = np.bincount(codes.ravel(), minlength=n_codes)
    surprisal = -np.log(counts / codes.size, where=counts > 0, out=np.zeros(n_codes))
    return surprisal[codes].astype(np.float32)


BLUR_SHARE = 0.015
"""Baseline maps are blurred, and their points kept apart, by 1.5 % of the image diagonal:
about the hit radius of both quality benchmarks, and the best of 1-2.5 % for them on the
real images."""


def baseline_params(shape: tuple[int, ...]) -> VisionParams:
    """Peak picking for baseline maps: blur sigma = separation = 1.5 % of the diagonal.

    Spelled out rather than derived from a profile, so tuning a profile never moves them.
    """
    return VisionParams(
        blur=BLUR_SHARE * math.hypot(shape[0], shape[1]), blur_mode="sigma", top_n=3
    )


def points_from_map(saliency: np.ndarray, blur: bool) -> list[InterestPoint]:
    """Pick points from a baseline map with the pipeline's own peak picker."""
    grid = saliency.astype(np.float32)
    params = baseline_params(grid.shape)
    if blur:
        grid = cv2.GaussianBlur(grid, (0, 0), params.sigma(grid.shape))
    return find_points(InterestMap(grid, 1, grid.shape), params)


def random_points(shape: tuple[int, int], n: int, rng: np.random.Generator) -> list[InterestPoint]:
    rows, cols = shape
    return [
        InterestPoint(i + 1, float(rng.uniform(0, cols)), float(rng.uniform(0, rows)), 0.0)
        for i in range(n)
    ]
