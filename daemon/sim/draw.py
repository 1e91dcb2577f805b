"""Drawing pieces the benchmark regimes share: beds from a chosen palette, ledge shadows clear
of the targets, the quasi-mosaic finish, the clearance between objects and the label image.

They follow ``scene.outcrop_scene``'s drawing (``_noise``, ``SKY_SHADE``) and its sizes, scaled
from its 216x288 reference mosaic.
"""

from __future__ import annotations

import cv2
import numpy as np

from .scene import SKY_SHADE, _noise

__all__ = [
    "beds",
    "clearance",
    "darken",
    "finish",
    "grow",
    "label_image",
    "ledge_shadows",
    "length_scale",
]

_SKY = np.array([225, 190, 150], np.float32)
"""BGR of the sky strip at the top of a view, darkening towards the horizon."""


def length_scale(shape: tuple[int, int]) -> float:
    """Length scale relative to the 216x288 reference mosaic, as ``outcrop_scene`` uses."""
    return min(shape[0] / 216.0, shape[1] / 288.0)


def beds(
    rng: np.random.Generator,
    shape: tuple[int, int],
    palette: np.ndarray,
    n_beds: int,
    *,
    sky: int = 0,
    grain: float = 0.07,
    lamination: float = 0.03,
    jitter: float = 0.1,
) -> tuple[np.ndarray, np.ndarray]:
    """Layered beds as ``outcrop_scene`` draws them, from a chosen palette.

    Contacts undulate and dip; each bed gets its own colour, lamination and grain. The
    regimes need other palettes (pale gypsum, dark host rock, no bed sharing a large
    target's colour) and the grain field, to texture large targets like the rock around
    them. ``sky`` rows at the top are sky. Each channel of a bed's colour varies by up to
    ``jitter`` (relative); pale beds need less, or they turn pink and green. Returns the
    float32 BGR image and the grain.
    """
    rows, cols = shape
    scale = length_scale(shape)
    img = np.zeros((rows, cols, 3), np.float32)
    xs = np.arange(cols, dtype=np.float32)
    yy = np.arange(rows, dtype=np.float32)[:, None]
    colours = palette[rng.choice(len(palette), n_beds, replace=True)]
    cuts = np.sort(rng.uniform(sky, rows, n_beds - 1))
    dip = rng.uniform(-0.08, 0.08)
    bed = np.zeros(shape, np.int32)
    for c in cuts:
        period = rng.uniform(60, 200) * scale
        wave = c + dip * (xs - cols / 2)
        wave += rng.uniform(2, 6) * scale * np.sin(2 * np.pi * xs / period + rng.uniform(0, 6.3))
        bed += (yy > wave[None, :]).astype(np.int32)
    texture = _noise(rng, shape, (0.0, 1.5 * scale, 6.0 * scale))
    laminae = np.sin(yy * rng.uniform(0.6, 1.4) / scale + 0.3 * texture)
    for k in range(n_beds):
        m = bed == k
        colour = colours[k] * rng.uniform(1 - jitter, 1 + jitter, 3)
        img[m] = colour[None, :] * (1.0 + grain * texture[m] + lamination * laminae[m])[:, None]
    if sky:
        img[:sky] = _SKY * np.linspace(1.0, 0.8, sky, dtype=np.float32)[:, None, None]
    return img, texture


def ledge_shadows(
    rng: np.random.Generator,
    shape: tuple[int, int],
    count: int,
    top: int,
    avoid: np.ndarray,
    *,
    length: tuple[float, float] = (25.0, 70.0),
) -> np.ndarray:
    """Masks of ``count`` ledge shadows (elongated ellipses, sizes as ``outcrop_scene``'s)
    below row ``top``, each clear of ``avoid``: a decoy must not cover a target, or a point
    would be both a hit and a decoy."""
    rows, cols = shape
    scale = length_scale(shape)
    shadow = np.zeros(shape, bool)
    placed = 0
    for _ in range(50 * count):
        if placed == count:
            break
        cy = rng.uniform(top + 10 * scale, rows - 5 * scale)
        cx = rng.uniform(0, cols)
        axes = (int(rng.uniform(*length) * scale), max(2, int(rng.uniform(4, 10) * scale)))
        m = np.zeros(shape, np.uint8)
        cv2.ellipse(m, (int(cx), int(cy)), axes, rng.uniform(-10, 10), 0, 360, 1, -1)
        if (m.astype(bool) & avoid).any():
            continue
        shadow |= m.astype(bool)
        placed += 1
    return shadow


def darken(img: np.ndarray, shadow: np.ndarray, factor: float) -> None:
    """Shade like ``outcrop_scene``: dark and slightly blue, lit by the sky only."""
    img[shadow] *= SKY_SHADE * factor


def finish(
    rng: np.random.Generator,
    img: np.ndarray,
    tiles: tuple[int, int] = (3, 4),
    exposure: float = 0.05,
    noise: float = 3.0,
) -> np.ndarray:
    """Quasi-mosaic look: each butted tile gets its own exposure, then sensor noise."""
    rows, cols = img.shape[:2]
    trows, tcols = tiles
    for i in range(trows):
        for j in range(tcols):
            r0, r1 = i * rows // trows, (i + 1) * rows // trows
            c0, c1 = j * cols // tcols, (j + 1) * cols // tcols
            img[r0:r1, c0:c1] *= rng.uniform(1 - exposure, 1 + exposure)
    img += rng.normal(0.0, noise, img.shape).astype(np.float32)
    return np.clip(img, 0, 255).astype(np.uint8)


def grow(mask: np.ndarray, pixels: float) -> np.ndarray:
    """``mask`` dilated by a disc of radius ``pixels``: the clearance kept between objects."""
    size = 2 * round(pixels) + 1
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    return cv2.dilate(mask.astype(np.uint8), kernel).astype(bool)


def clearance(shape: tuple[int, int]) -> float:
    """Gap kept between a target and anything else: more than the bench's hit tolerance
    (6 px at 216x288, scaled with the diagonal), so each point hits one object at most."""
    return 8.0 * float(np.hypot(*shape)) / 360.0


def label_image(shape: tuple[int, int], masks: list[np.ndarray]) -> np.ndarray:
    """uint8 labels: i + 1 where mask i is set and no earlier mask is."""
    labels = np.zeros(shape, np.uint8)
    for i, m in enumerate(masks):
        labels[m & (labels == 0)] = i + 1
    return labels
