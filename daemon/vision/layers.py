"""Layers: class regions that run across the view from side to side.

An outcrop is bedded, and a thin bed of an unusual colour is a rare class (its area is
small because it is thin) though it is the outcrop's structure, not a thing on it; the two
contacts that bound it, close together, are rare texture. On generated outcrops such beds
were the commonest reason a spot, a vein or a lichen lost first place. A class region is a
*layer* as far as it spans the view's width (0 at 60 % of it, 1 from 95 %) and is thicker
than a line (its area over its width: 0 at 0.6 % of the image diagonal, 1 from 1.8 %), so
a vein or a crack crossing the view keeps its rarity. Side to side only: the bedding of an
outcrop seen upright runs across the view, and a dyke or a crack cutting it from top to
bottom is an anomaly. A region is measured with gaps of up to ``_BRIDGE`` pixels bridged,
so a bed broken by a few unsegmented pixels is still one bed.

The discount is partial (``VisionParams.layers``): a rare layer still counts, only less
than a thing of the same rarity on it.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .cooccurrence import Segmentation
from .kernels import kernel

__all__ = ["discount_texture", "discount_uncommon", "layer_share"]

_SPAN = (0.6, 0.95)
"""Width shares of the view over which a region goes from no layer to a whole one. A lens
along the bedding (aspect 2.5-4) can reach three quarters of the view and is a thing on the
outcrop."""
_THICK = (0.006, 0.018)
"""Mean thickness (area / width), as shares of the image diagonal, over which a region goes
from a line (a vein, a crack: no layer) to a bed."""
_BRIDGE = 2
"""Gaps of up to this many pixels inside a class region are bridged when it is measured."""
_CONTACT = 3
"""Texture within this many pixels of a layer counts as the layer's (its contacts)."""
_TEXTURE_SHARE = 0.5
"""Texture is discounted half as much as the classes: rare texture along a contact is a
weaker sign of a bed than the bed's own class."""


def _ramp(value: float, lo: float, hi: float) -> float:
    return min(1.0, max(0.0, (value - lo) / (hi - lo)))


def layer_share(seg: Segmentation) -> np.ndarray:
    """How much each pixel's class region is a layer, (M, N) float32 in 0..1.

    The largest class (the rock the view is mostly of) and unsegmented pixels score 0.

    Examples
    --------
    >>> from cyborg.daemon.vision.segment import segment_plane
    >>> from cyborg.daemon.vision.params import PAPER
    >>> plane = np.full((120, 160), 100, np.uint8)
    >>> plane[50:60, :] = 200                    # a pale bed across the view
    >>> plane[20:30, 70:80] = 30                 # a dark spot
    >>> plane[70:110, 120:122] = 30              # a dark vein, top to bottom
    >>> share = layer_share(segment_plane(plane, PAPER))
    >>> float(share[55, 80]), float(share[25, 75]), float(share[90, 121])
    (1.0, 0.0, 0.0)
    """
    rows, cols = seg.labels.shape
    diag = math.hypot(rows, cols)
    share = np.zeros((rows, cols), np.float32)
    if seg.k < 2:
        return share
    bridge = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * _BRIDGE + 1, 2 * _BRIDGE + 1))
    # A class's core (its mask eroded: speckle and lines gone, what could be a bed) is where
    # a pixel's whole 3 x 3 neighbourhood in the frame holds its label: the lowest and the
    # highest label there are the same. One pass tells each class's columns and rows.
    lowest, highest = cv2.erode(seg.labels, None), cv2.dilate(seg.labels, None)
    spans, first, last = _core_spans(lowest, highest, seg.k)
    for k in range(2, seg.k + 1):
        if spans[k] <= _SPAN[0] * cols:
            continue  # spans too little to be a layer: most classes, cheaply
        # Only the rows a bed's core reaches (and the bridge around them) are labelled.
        r0, r1 = max(0, first[k] - 2 * _BRIDGE), min(rows, last[k] + 2 * _BRIDGE + 1)
        mask = cv2.compare(seg.labels[r0:r1], k, cv2.CMP_EQ)
        _, regions, stats, _ = cv2.connectedComponentsWithStats(
            cv2.dilate(mask, bridge), connectivity=8
        )
        for j in np.nonzero(stats[1:, cv2.CC_STAT_WIDTH] > _SPAN[0] * cols)[0] + 1:
            width = int(stats[j, cv2.CC_STAT_WIDTH])
            region = (regions == j) & (mask > 0)
            thick = float(np.count_nonzero(region)) / width / diag
            s = _ramp(width / cols, *_SPAN) * _ramp(thick, *_THICK)
            if s > 0:
                share[r0:r1][region] = s
    return share


@kernel
def _core_spans(lowest: np.ndarray, highest: np.ndarray, k: int) -> tuple:
    """For each label 0..``k``: how many columns its core reaches, and the first and the
    last row it reaches (-1 where it has none); a core pixel is one whose ``lowest`` and
    ``highest`` label around it are the same."""
    rows, cols = lowest.shape
    seen = np.zeros((k + 1, cols), np.bool_)
    first = np.full(k + 1, -1, np.int64)
    last = np.full(k + 1, -1, np.int64)
    for y in range(rows):
        low, high = lowest[y], highest[y]
        for x in range(cols):
            label = low[x]
            if label == high[x]:
                seen[label, x] = True
                if first[label] < 0:
                    first[label] = y
                last[label] = y
    return seen.sum(axis=1), first, last


def discount_uncommon(umap: np.ndarray, share: np.ndarray, strength: float) -> np.ndarray:
    """The uncommon map with each pixel's rarity above the commonest class's (1) cut by
    ``strength`` x its layer share; unsegmented pixels (0) stay 0.

    Examples
    --------
    >>> umap = np.array([[0.0, 1.0, 5.0, 5.0]], np.float32)
    >>> share = np.array([[0.0, 1.0, 1.0, 0.0]], np.float32)
    >>> discount_uncommon(umap, share, 0.5).tolist()
    [[0.0, 1.0, 3.0, 5.0]]
    """
    return _discounted(umap, share, np.float32(strength))


@kernel
def _discounted(umap: np.ndarray, share: np.ndarray, strength: np.float32) -> np.ndarray:
    """:func:`discount_uncommon` in one pass, float32 operation for operation."""
    out = np.empty(umap.shape, np.float32)
    one, zero = np.float32(1.0), np.float32(0.0)
    for y in range(umap.shape[0]):
        for x in range(umap.shape[1]):
            value = umap[y, x]
            out[y, x] = value - max(value - one, zero) * (share[y, x] * strength)
    return out


def discount_texture(texture: np.ndarray, shares: list[np.ndarray], strength: float) -> np.ndarray:
    """Texture rarity cut by ``strength`` x ``_TEXTURE_SHARE`` x the strongest layer share
    (over the planes) within ``_CONTACT`` pixels: a thin bed's two contacts are rare texture
    only because the bed is thin."""
    near = cv2.dilate(
        np.maximum.reduce(shares),
        cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * _CONTACT + 1, 2 * _CONTACT + 1)),
    )
    return _cut(texture, near, np.float32(strength * _TEXTURE_SHARE))


@kernel
def _cut(texture: np.ndarray, near: np.ndarray, strength: np.float32) -> np.ndarray:
    """texture x (1 - near x strength) in one pass, float32 operation for operation."""
    out = np.empty(texture.shape, np.float32)
    one = np.float32(1.0)
    for y in range(texture.shape[0]):
        for x in range(texture.shape[1]):
            out[y, x] = texture[y, x] * (one - near[y, x] * strength)
    return out
