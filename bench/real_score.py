"""Hits, scores and noisy looks of one real image, for ``bench.real`` (whose docstring
defines the scoring)."""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from cyborg.daemon.sim.camera_effects import jpeg_round_trip
from cyborg.daemon.vision.interest import InterestPoint

HIT_SHARE = 0.015
"""Hit radius, as a share of the image diagonal."""
REPEAT_SHARE = 0.03
"""Two looks' best points repeat within this share of the diagonal."""
NOISE_SIGMA = 2.0
TOP_N = 3


def diagonal(shape: tuple[int, ...]) -> float:
    return math.hypot(shape[0], shape[1])


def near_mask(mask: np.ndarray) -> np.ndarray:
    """bool mask of pixels within the hit radius of a target pixel (mask > 0)."""
    target = (mask > 0).astype(np.uint8)
    if not target.any():
        return np.zeros(mask.shape, bool)
    dist = cv2.distanceTransform(1 - target, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return dist <= HIT_SHARE * diagonal(mask.shape)


def hits(near: np.ndarray, points: Sequence[InterestPoint]) -> list[bool]:
    """Hit flags of the first ``TOP_N`` points (rounded, clipped into the image)."""
    rows, cols = near.shape
    return [
        bool(near[min(rows - 1, max(0, round(p.y))), min(cols - 1, max(0, round(p.x)))])
        for p in points[:TOP_N]
    ]


def score(flags: list[bool]) -> dict[str, float]:
    return {
        "top1": float(bool(flags) and flags[0]),
        "any3": float(any(flags)),
        "p3": sum(flags) / TOP_N,
    }


def looks(image: np.ndarray, seed: int, jpeg: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Two noisy looks at the same image, the same for every method; with ``jpeg``, each
    through a JPEG at that quality after its noise, as a camera saves a frame."""
    rng = np.random.default_rng([seed, 2])
    out = []
    for _ in range(2):
        noisy = np.clip(np.rint(image + rng.normal(0.0, NOISE_SIGMA, image.shape)), 0, 255)
        look = noisy.astype(np.uint8)
        out.append(look if jpeg is None else jpeg_round_trip(look, jpeg))
    return out[0], out[1]
