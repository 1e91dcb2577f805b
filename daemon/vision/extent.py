"""How big a target is: the extent of what an interest point found, measured on the image.

A point's ``radius`` (``peaks``) is that of its patch on the blurred interest map. The blur
that lets a score sum a neighbourhood also spreads it, so the patch of a target a few blur
widths across or less is mostly blur: a plant 15 px across in a 300 m mosaic has a patch
about 30 px across. The patch says where to look, and how far apart two targets must be;
the target's own extent is measured on the image: the pixels near the point whose colour is
nearer the point's than its surroundings', connected to it.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

__all__ = ["target_radius"]

_CORE = 0.25
"""The point's colour is taken within this share of the patch radius (at least 1.5 px): the
median of the half of those pixels farther in colour from the surroundings, so a point
astride the target's edge (the blurred map's centre is not the target's) sees the target."""
_AROUND = (1.5, 2.5)
"""Its surroundings' colour is the median between these multiples of the patch radius."""
_CONTRAST = 1.5
"""A colour this many times the surroundings' own spread (median absolute deviation) away
from theirs is a target by colour; nearer, it is one by texture and keeps its patch."""


def target_radius(image: np.ndarray, x: float, y: float, reach: float) -> float:
    """Radius (pixels) of a disc of the area of the target at (``x``, ``y``).

    Parameters
    ----------
    image : (M, N, 3) uint8 ndarray
        The analysed view, BGR.
    x, y : float
        The point: column and row, pixel centres at integers.
    reach : float
        The point's patch radius (pixels): the target lies within 1.5 times it.

    Returns
    -------
    float
        The radius of a disc of the target's area: its pixels nearer in colour (CIELAB,
        lightly smoothed) to the point's than to the surroundings', connected to the point,
        within 1.5 ``reach``. ``reach`` itself when the point differs from its surroundings
        by texture rather than colour, or when the image holds no surroundings.

    Examples
    --------
    >>> rock = np.full((200, 200, 3), (60, 100, 140), np.uint8)
    >>> plant = cv2.circle(rock.copy(), (90, 110), 8, (40, 150, 110), -1)
    >>> round(target_radius(plant, 90.0, 110.0, 16.0), 1)  # a disc drawn with radius 8
    7.8
    >>> target_radius(rock, 90.0, 110.0, 16.0)  # nothing there by colour
    16.0
    """
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"need an (M, N, 3) image, got shape {image.shape}")
    reach = max(float(reach), 1.0)
    rows, cols = image.shape[:2]
    half = math.ceil(_AROUND[1] * reach) + 2
    r0, r1 = max(0, math.floor(y) - half), min(rows, math.ceil(y) + half + 1)
    c0, c1 = max(0, math.floor(x) - half), min(cols, math.ceil(x) + half + 1)
    if r1 <= r0 or c1 <= c0:
        return reach
    window = cv2.GaussianBlur(image[r0:r1, c0:c1], (0, 0), 1.0)
    lab = cv2.cvtColor(window, cv2.COLOR_BGR2LAB).astype(np.float32)
    yy, xx = np.ogrid[r0:r1, c0:c1]
    dist = np.hypot(xx - x, yy - y)
    core = dist <= max(1.5, _CORE * reach)
    around = (dist > _AROUND[0] * reach) & (dist <= _AROUND[1] * reach)
    if not core.any() or around.sum() < 8:
        return reach
    theirs = np.median(lab[around], axis=0)
    seen = lab[core]
    apart = np.linalg.norm(seen - theirs, axis=1)
    own = np.median(seen[apart >= np.median(apart)], axis=0)  # a point astride an edge
    spread = np.median(np.linalg.norm(lab[around] - theirs, axis=1))
    if np.linalg.norm(own - theirs) <= _CONTRAST * max(float(spread), 1.0):
        return reach
    nearer = np.linalg.norm(lab - own, axis=2) < np.linalg.norm(lab - theirs, axis=2)
    mask = (nearer & (dist <= _AROUND[0] * reach)).astype(np.uint8)
    _, labels = cv2.connectedComponents(mask, connectivity=8)
    held = labels[core & (mask > 0)]
    if held.size == 0:
        return reach
    area = int((labels == np.bincount(held).argmax()).sum())
    return math.sqrt(area / math.pi)
