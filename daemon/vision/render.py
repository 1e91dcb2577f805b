"""Pictures of the science products, drawn the way the seed papers drew them."""

from __future__ import annotations

import cv2
import numpy as np

from cyborg.protocol.palette import POINT_RGB, bgr

from .cooccurrence import Segmentation
from .interest import InterestPoint

__all__ = [
    "CLASS_COLOURS",
    "POINT_COLOURS",
    "cooccurrence_plot",
    "grey_ramp",
    "overlay",
    "segmentation_image",
]

CLASS_COLOURS_RGB = (
    (255, 0, 0),  # red: largest class
    (0, 0, 255),  # blue
    (160, 32, 240),  # purple
    (0, 200, 0),  # green
    (0, 255, 255),  # cyan
    (255, 255, 0),  # yellow
    (255, 255, 255),  # white
    (255, 165, 0),  # orange: smallest of 8
)
CLASS_COLOURS = tuple((b, g, r) for r, g, b in CLASS_COLOURS_RGB)
"""BGR colour of class k at index k - 1, in the paper's order by class area."""

POINT_COLOURS = tuple(bgr(rgb) for rgb in POINT_RGB)
"""BGR colour of interest point k at index k - 1 (``protocol.palette``: orange, sky blue,
vermillion)."""

_LUT = np.zeros((256, 1, 3), np.uint8)
for _k, _c in enumerate(CLASS_COLOURS, start=1):
    _LUT[_k, 0] = _c


def segmentation_image(seg: Segmentation) -> np.ndarray:
    """Colour-code a segmentation: (M, N, 3) uint8 BGR, black = unsegmented.

    Examples
    --------
    >>> seg = Segmentation(np.array([[0, 1, 2]], np.uint8), (), np.zeros((256, 256), np.float32))
    >>> segmentation_image(seg)[0].tolist()
    [[0, 0, 0], [0, 0, 255], [255, 0, 0]]
    """
    return cv2.LUT(cv2.merge([seg.labels] * 3), _LUT)


def grey_ramp(values: np.ndarray, vmax: float | None = None) -> np.ndarray:
    """Map values 0..vmax linearly to grey 0..255: (M, N) uint8.

    Examples
    --------
    >>> grey_ramp(np.array([[0.0, 4.0, 8.0]]), vmax=8).tolist()
    [[0, 128, 255]]
    """
    top = float(values.max()) if vmax is None else float(vmax)
    if top <= 0:
        return np.zeros(values.shape, np.uint8)
    return cv2.convertScaleAbs(values.astype(np.float32), alpha=255.0 / top)


def cooccurrence_plot(seg: Segmentation, size: int = 512) -> np.ndarray:
    """The pair histogram on a log scale with each class's region in its colour: the block
    of values it owns (a square on the diagonal) or its disc.

    Row = first value (top = 0), column = neighbour value; (size, size, 3) uint8 BGR.
    """
    hist = np.log1p(seg.histogram.astype(np.float32))
    img = grey_ramp(hist)
    img = cv2.resize(img, (size, size), interpolation=cv2.INTER_NEAREST)
    img = cv2.applyColorMap(img, cv2.COLORMAP_BONE)
    scale = size / 256.0
    for k, cls in enumerate(seg.classes, start=1):
        colour = CLASS_COLOURS[k - 1]
        if cls.is_block:
            lo, hi = round(cls.lo * scale), round((cls.hi + 1) * scale) - 1
            cv2.rectangle(img, (lo, lo), (hi, hi), colour, 2, cv2.LINE_AA)
            continue
        centre = (round((cls.center + 0.5) * scale),) * 2
        cv2.circle(img, centre, max(2, round(cls.radius * scale)), colour, 2, cv2.LINE_AA)
    cv2.line(img, (0, 0), (size - 1, size - 1), (80, 80, 80), 1)
    return img


def overlay(bgr: np.ndarray, points: list[InterestPoint], scale: float = 1.0) -> np.ndarray:
    """Draw the interest points on a copy of the image, best first (``POINT_COLOURS``).

    Each ring lies outside the point's radius, so it frames the target instead of hiding
    it, and its number stands beside it. ``scale`` converts point coordinates to ``bgr``
    pixels (input vs analysed image).
    """
    out = bgr.copy()
    rows, cols = out.shape[:2]
    thick = max(1, round(min(rows, cols) / 300))
    font = 0.45 * thick
    for p in points:
        colour = POINT_COLOURS[p.rank - 1] if p.rank <= len(POINT_COLOURS) else (0, 255, 255)
        centre = (round(p.x * scale), round(p.y * scale))
        r = max(4, round(1.25 * p.radius * scale) + 2 * thick)
        cv2.circle(out, centre, r, (0, 0, 0), thick + 2, cv2.LINE_AA)
        cv2.circle(out, centre, r, colour, thick, cv2.LINE_AA)
        label = str(p.rank)
        (tw, th), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, font, thick)
        x = (
            centre[0] + r + 2 * thick
            if centre[0] + r + tw + 4 * thick < cols
            else centre[0] - r - tw - 2 * thick
        )
        y = min(max(centre[1] + th // 2, th + 1), rows - 2)
        cv2.putText(
            out, label, (x, y), cv2.FONT_HERSHEY_SIMPLEX, font, (0, 0, 0), thick + 2, cv2.LINE_AA
        )
        cv2.putText(out, label, (x, y), cv2.FONT_HERSHEY_SIMPLEX, font, colour, thick, cv2.LINE_AA)
    return out
