"""No-data fill: the black beyond a panorama's edge or around a registered mosaic tile.

A mosaic, a registered panorama or a frame looking past the simulated panorama's edge
(``camera.simulated.NO_DATA``) holds pixels that are not image. Left in, their black is a
class of its own in every plane, rare or common by nothing but the framing, and the step at
their edge is the strongest texture and line in view: the best point sits on the edge and
jumps along it from one look to the next.

**The rule.** A pixel is fill when its 5 x 5 neighbourhood (``_WINDOW``) has a mean intensity
(mean of B, G, R) of at most ``_DARK`` and a standard deviation of at most ``_FLAT`` (8-bit
values), and it belongs to an 8-connected run of such pixels that touches the frame and
covers at least ``_MIN_SHARE`` of the image; it then grows over its rim, up to ``_GROW``
pixels of near-black (every channel at most ``_RIM``: the window's edge, a JPEG's ringing).
Exact (0, 0, 0) passes whatever the camera's noise did around it: sensor noise of sigma 2 on
a black fill, clipped at 0, has a mean under 1, and so does a JPEG of it. A real shadow is
not fill: the deepest Navcam rover shadows have a mean of 4 to 5 and the dark rock of an
underexposed photograph more; a dark patch inside the frame is not connected to it, and a
speck of crushed black is too small.

The science then treats fill as the outside of the frame (``pipeline.analyze``): it is
never segmented (no class, no pair in a co-occurrence histogram, no class area), its
pixels, and those within ``MARGIN`` of them, are scored at the view's typical level (as the
blur counts the outside of the frame), and texture, lines and shade are judged on the image
with the fill replaced by a smooth continuation of the rock beside it (:func:`fill`), so the
fill's edge is no contrast.
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["MARGIN", "beside", "fill", "neutral", "no_data_mask"]

_DARK_PIXEL = 8
"""No pixel with every channel at most this: no fill, whatever its neighbours (a fast exit)."""
_WINDOW = 5
"""Side of the neighbourhood whose mean and spread judge a pixel (analysed pixels)."""
_DARK = 2.0
"""Highest neighbourhood mean intensity of fill (8-bit): black plus clipped sensor noise."""
_FLAT = 3.0
"""Highest neighbourhood standard deviation of fill (8-bit)."""
_RIM = 32
"""Brightest channel of the fill's rim: a JPEG at quality 75 rings a black fill up to ~27
beside a bright edge."""
_GROW = 8
"""Steps (pixels) the fill grows over its near-black rim: one JPEG block."""
_MIN_SHARE = 0.0025
"""Smallest fill, as a share of the image: a speck of crushed black is image."""
MARGIN = 8
"""Pixels (analysed) beside the fill scored at the typical level too: texture's widest
contrast scale (sigma 4) and the JPEG block a fill's edge rings in still see the edge."""
_CONTINUE = 8.0
"""Gaussian sigma (pixels) of the continuation that replaces fill: the rock beside it."""


def no_data_mask(bgr: np.ndarray) -> np.ndarray | None:
    """The no-data fill of an image (the rule in the module docstring), or None when none.

    Parameters
    ----------
    bgr : (M, N, 3) uint8 ndarray
        Not modified.

    Returns
    -------
    (M, N) bool ndarray or None
        True on fill.

    Examples
    --------
    >>> img = np.full((40, 60, 3), 120, np.uint8)
    >>> img[:, 45:] = 0                                # a tile's black fill on the right
    >>> img[10:16, 10:16] = 0                          # a black speck inside: image
    >>> mask = no_data_mask(img)
    >>> bool(mask[:, 45:].all()), bool(mask[:, :45].any())
    (True, False)
    >>> no_data_mask(np.full((40, 60, 3), 3, np.uint8)) is None  # dark rock, not fill
    True
    """
    if bgr.ndim != 3 or bgr.shape[2] != 3 or bgr.dtype != np.uint8:
        raise ValueError(f"expected (M, N, 3) uint8, got {bgr.shape} {bgr.dtype}")
    rows, cols = bgr.shape[:2]
    black = cv2.inRange(bgr, (0, 0, 0), (_DARK_PIXEL,) * 3)
    if not black.any():
        return None  # the common case: not a single near-black pixel, nothing to judge
    grey = cv2.transform(bgr, np.full((1, 3), 1.0 / 3.0, np.float32)).astype(np.float32)
    size = (_WINDOW, _WINDOW)
    mean = cv2.blur(grey, size, borderType=cv2.BORDER_REPLICATE)
    square = cv2.blur(grey * grey, size, borderType=cv2.BORDER_REPLICATE)
    spread = cv2.subtract(square, cv2.multiply(mean, mean))
    dark = ((mean <= _DARK) & (spread <= _FLAT * _FLAT)).view(np.uint8)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(dark, connectivity=8)
    edge = np.zeros(count, bool)
    for side in (labels[0], labels[-1], labels[:, 0], labels[:, -1]):
        edge[side] = True
    keep = edge & (stats[:, cv2.CC_STAT_AREA] >= _MIN_SHARE * rows * cols)
    keep[0] = False  # label 0 is what is not dark
    if not keep.any():
        return None
    # Along the fill's edge the window holds rock, and a JPEG rings in the edge's blocks:
    # the fill grows over the near-black pixels beside it, up to a JPEG block.
    mask = keep[labels].view(np.uint8)
    near_black = cv2.inRange(bgr, (0, 0, 0), (_RIM,) * 3)
    step = np.ones((3, 3), np.uint8)
    for _ in range(_GROW):
        mask = cv2.bitwise_or(mask, cv2.bitwise_and(cv2.dilate(mask, step), near_black >> 7))
    mask = mask.view(bool)
    return None if mask.all() else mask  # all black: no image to tell it from


def fill(bgr: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """A copy of ``bgr`` with the fill replaced by a smooth continuation of the image
    beside it (normalised convolution, sigma ``_CONTINUE``), and by the image's median
    colour where no image is near: texture, lines and shade then see no step at its edge.

    Examples
    --------
    >>> img = np.full((20, 30, 3), (60, 110, 160), np.uint8)
    >>> mask = np.zeros((20, 30), bool)
    >>> mask[:, 20:] = True
    >>> fill(np.where(mask[..., None], 0, img).astype(np.uint8), mask)[5, 25].tolist()
    [60, 110, 160]
    """
    valid = (~mask).astype(np.float32)
    image = bgr.astype(np.float32) * valid[..., None]
    sigma = _CONTINUE
    weight = cv2.GaussianBlur(valid, (0, 0), sigma, borderType=cv2.BORDER_CONSTANT)
    spread = cv2.GaussianBlur(image, (0, 0), sigma, borderType=cv2.BORDER_CONSTANT)
    typical = np.median(bgr[~mask], axis=0).astype(np.float32)
    # Far from any image the weight vanishes; the median colour takes over smoothly.
    near = np.minimum(weight / np.float32(0.05), 1.0)[..., None]
    guess = spread / np.maximum(weight, 1e-6)[..., None]
    continued = near * guess + (1.0 - near) * typical
    out = bgr.copy()
    out[mask] = np.clip(np.rint(continued[mask]), 0, 255).astype(np.uint8)
    return out


def beside(mask: np.ndarray) -> np.ndarray:
    """The fill and every pixel within ``MARGIN`` of it (a square reach): what is not scored.

    >>> mask = np.zeros((1, 20), bool)
    >>> mask[0, 15:] = True
    >>> int(np.flatnonzero(beside(mask)[0])[0])
    7
    """
    kernel = np.ones((2 * MARGIN + 1, 2 * MARGIN + 1), np.uint8)
    return cv2.dilate(mask.view(np.uint8), kernel).view(bool)


def neutral(score: np.ndarray, band: np.ndarray) -> np.ndarray:
    """``score`` with the pixels of ``band`` set to the median of the others (a new array):
    the typical level, which the interest map's median keeps and its blur counts the
    outside of the frame as.

    >>> neutral(np.array([[1.0, 5.0, 2.0, 9.0]], np.float32), np.array([[0, 0, 0, 1]], bool))
    array([[1., 5., 2., 2.]], dtype=float32)
    """
    out = score.copy()
    if band.all():
        out[:] = 0
        return out
    out[band] = np.median(score[~band])
    return out
