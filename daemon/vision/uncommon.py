"""Uncommon maps: each pixel scored by how rare its class is in its plane.

The seed: classes ranked by area, the ranking reversed linearly, so the largest class scores
1 and the smallest 8 (K <= 8 classes). Unsegmented pixels score 0 (they are drawn black and must not
attract interest). Variants, all monotone in class area so still "uncommon maps":

* ``spread``: 1 + 7 (r - 1) / (K - 1): the largest class scores 1 and the rarest 8, as the
  seed states it, whatever the number of classes (the ``paper`` profile).
* ``rank``: r in 1..K, which meets the seed's statement only when K = 8.
* ``surprisal``: 1 + 7 log(A_1 / A_k) / log(span), clipped to 1..8, so a tiny class scores
  far above a mid-sized one instead of one rank step above it.

``value_rarity`` > 0 adds, on segmented pixels, that weight times the rarity of the pixel's
own value among region interiors (7 log(d_max / d(v)) / log(span), clipped to 0..7, d the
smoothed diagonal profile): the dark tail of one broad class, where a crack or a pit lies,
scores above the class's core.
"""

from __future__ import annotations

import cv2
import numpy as np

from .cooccurrence import Segmentation
from .kernels import kernel
from .params import VisionParams

__all__ = ["UncommonWindows", "uncommon_map", "uncommon_values", "value_rarity"]


def uncommon_values(seg: Segmentation, params: VisionParams) -> np.ndarray:
    """Uncommon value of each label: a float64 array of 256, entry 0 (unsegmented) = 0.

    Examples
    --------
    >>> from cyborg.daemon.vision.cooccurrence import PlaneClass
    >>> from cyborg.daemon.vision.params import PAPER
    >>> cls = tuple(PlaneClass(c, 3, 1.0, a) for c, a in [(10, 900), (90, 90), (200, 9)])
    >>> seg = Segmentation(np.zeros((1, 1), np.uint8), cls, np.zeros((256, 256), np.float32))
    >>> uncommon_values(seg, PAPER)[:4].tolist()
    [0.0, 1.0, 4.5, 8.0]
    >>> uncommon_values(seg, PAPER.replace(uncommon="rank"))[:4].tolist()
    [0.0, 1.0, 2.0, 3.0]
    >>> uncommon_values(seg, PAPER.replace(uncommon="surprisal"))[:4].round(2).tolist()
    [0.0, 1.0, 3.33, 5.67]
    """
    values = np.zeros(256, np.float64)
    k = seg.k
    if k == 0:
        return values
    ranks = np.arange(1, k + 1, dtype=np.float64)
    if params.uncommon == "rank":
        scores = ranks
    elif params.uncommon == "spread":
        scores = np.ones(k) if k == 1 else 1.0 + 7.0 * (ranks - 1.0) / (k - 1.0)
    else:
        areas = np.array([max(c.area, 1) for c in seg.classes], np.float64)
        ratio = np.log(areas[0] / areas) / np.log(params.surprisal_span)
        scores = 1.0 + 7.0 * np.clip(ratio, 0.0, 1.0)
    values[1 : k + 1] = scores
    return values


def value_rarity(seg: Segmentation, params: VisionParams) -> np.ndarray:
    """Rarity 0..7 of each coded value among region interiors: float32 array of 256.

    Examples
    --------
    >>> from cyborg.daemon.vision.params import PAPER
    >>> prof = np.zeros(256)
    >>> prof[[10, 11, 12]] = [1000.0, 10.0, 1.0]
    >>> seg = Segmentation(np.zeros((1, 1), np.uint8), (), np.zeros((256, 256)), profile=prof)
    >>> [round(float(v), 2) for v in value_rarity(seg, PAPER)[[10, 11, 12, 13]]]
    [0.0, 4.67, 7.0, 7.0]
    """
    prof = seg.profile
    if prof is None or prof.max() <= 0:
        return np.zeros(256, np.float32)
    ratio = prof.max() / np.maximum(prof, prof.max() * 1e-12)
    return (7.0 * np.clip(np.log(ratio) / np.log(params.surprisal_span), 0, 1)).astype(np.float32)


def uncommon_map(seg: Segmentation, params: VisionParams) -> np.ndarray:
    """Score every pixel of a segmentation by the rarity of its class.

    Parameters
    ----------
    seg : Segmentation
    params : VisionParams
        Uses ``uncommon`` and ``surprisal_span``.

    Returns
    -------
    (M, N) float32 ndarray
        0 for unsegmented pixels, else 1..8 (plus up to 7 x ``value_rarity``).

    Examples
    --------
    >>> from cyborg.daemon.vision.segment import segment_plane
    >>> from cyborg.daemon.vision.params import PAPER
    >>> plane = np.full((20, 40), 40, np.uint8)
    >>> plane[:, 30:] = 200
    >>> umap = uncommon_map(segment_plane(plane, PAPER), PAPER)
    >>> umap[0, [0, 39]].tolist()
    [1.0, 8.0]
    """
    table = uncommon_values(seg, params).astype(np.float32)
    if params.value_rarity > 0 and seg.values is not None and seg.k:
        tail = value_rarity(seg, params) * np.float32(params.value_rarity)
        return _with_tail(seg.labels, seg.values, table, tail)
    return cv2.LUT(seg.labels, table)


@kernel
def _with_tail(
    labels: np.ndarray, values: np.ndarray, table: np.ndarray, tail: np.ndarray
) -> np.ndarray:
    """table[label] + tail[value] where a pixel is labelled, table[label] elsewhere, float32:
    the two lookups, the mask and the sum in one pass."""
    out = np.empty(labels.shape, np.float32)
    for y in range(labels.shape[0]):
        for x in range(labels.shape[1]):
            label = labels[y, x]
            out[y, x] = table[label] + tail[values[y, x]] if label > 0 else table[label]
    return out


class UncommonWindows:
    """A plane's uncommon map read a window at a time: ``windows[box]`` is
    ``uncommon_map(seg, params)[box]``, value for value, without the full-size float map (4
    bytes per pixel) that the explanations would otherwise keep for a few windows.

    Examples
    --------
    >>> from cyborg.daemon.vision.segment import segment_plane
    >>> from cyborg.daemon.vision.params import PAPER
    >>> plane = np.full((20, 40), 40, np.uint8)
    >>> plane[:, 30:] = 200
    >>> seg = segment_plane(plane, PAPER)
    >>> box = np.s_[2:9, 25:36]
    >>> bool((UncommonWindows(seg, PAPER)[box] == uncommon_map(seg, PAPER)[box]).all())
    True
    """

    def __init__(self, seg: Segmentation, params: VisionParams) -> None:
        self._seg, self._params = seg, params

    def __getitem__(self, box: tuple[slice, slice]) -> np.ndarray:
        return uncommon_map(self._seg.window(box), self._params)
