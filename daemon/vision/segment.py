"""Labelling one 8-bit plane with the classes of its co-occurrence histogram (``cooccurrence``).

A pixel joins class k when at least ``min_votes`` of its 4 neighbour pairs fall in region k
(borders reflected); otherwise it stays **unsegmented** (label 0, drawn black).
Labels 1..K are ordered by class area: 1 is the largest class.

Fast labelling: each value v of class k is coded as u(v) = 32 k + q(v), with q(v) = round(15 (v -
g)^2 / r^2) <= 15 (one lookup table; q = 0 throughout a block), and w(v) = 32 k + 16 - q(v) is
derived from u by bit arithmetic. A pair (a, b) lies in the region of a common class exactly when
the saturating difference w(b) - u(a) is in 1..16, so the test is two SIMD passes per direction (the
disc edge is resolved to r^2 / 15). Values in no disc get u = 240, whose w is 224: no pair with them
lands in 1..16.
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np

from .cooccurrence import (
    BAND_PIXELS,
    PlaneClass,
    Segmentation,
    cooccurrence_histogram,
    diagonal_classes,
)
from .params import VisionParams

__all__ = ["segment_plane"]

_NONE = 240


def _value_tables(
    classes: tuple[PlaneClass, ...], value_counts: np.ndarray
) -> tuple[list[int], np.ndarray]:
    """Number the classes and code the values: (order, per-value u code).

    A value belongs to its block, or to the nearest peak whose disc holds it (ties: the higher peak,
    i.e. the earlier in ``classes``). Ids 1..K number the classes by expected area, the count of
    their values (``order[id - 1]`` indexes ``classes``), so the final ranking by exact area is
    usually the identity and costs no relabelling pass. A value in no disc gets ``_NONE``.
    """
    values = np.arange(256)
    best = np.full(256, np.inf)
    nearest = np.zeros(256, np.int64)
    q = np.zeros(256, np.int64)
    for k, c in enumerate(classes, start=1):
        if c.is_block:
            nearest[c.lo : c.hi + 1] = k
            continue
        dist = np.abs(values - c.center)
        inside = (dist <= c.radius) & (dist < best)
        best[inside] = dist[inside]
        nearest[inside] = k
        q[inside] = np.rint(15.0 * dist[inside] ** 2 / c.radius**2)
    expected = np.bincount(nearest, weights=value_counts, minlength=len(classes) + 1)[1:]
    order = sorted(range(len(classes)), key=lambda i: -expected[i])
    renumber = np.zeros(len(classes) + 1, np.int64)
    renumber[[i + 1 for i in order]] = np.arange(1, len(classes) + 1)
    cls = renumber[nearest]
    return order, np.where(cls > 0, 32 * (cls - 1) + np.minimum(q, 15), _NONE).astype(np.uint8)


def _w_codes(u: np.ndarray) -> np.ndarray:
    """w = 32 k + 16 - q from u = 32 k + q, in three SIMD passes (cheaper than a lookup)."""
    w = cv2.bitwise_and(u, 224)
    w += 16
    return cv2.subtract(w, cv2.bitwise_and(u, 31))


def _vote(u: np.ndarray, min_votes: int) -> np.ndarray:
    """uint8 mask (255 = enough neighbour pairs inside the pixel's class disc)."""
    w = _w_codes(u)
    # Borders are reflected (as the interest blur does): a pixel's missing pair mirrors the
    # pair on its other side, so border pixels are neither easier nor harder to label.
    count = np.zeros(u.shape, np.uint8)
    if u.shape[1] > 1:
        h = cv2.inRange(cv2.subtract(w[:, 1:], u[:, :-1]), 1, 16)
        h >>= 7
        both = cv2.copyMakeBorder(h, 0, 0, 1, 1, cv2.BORDER_REPLICATE)
        count = cv2.add(both[:, :-1], both[:, 1:])
    if u.shape[0] > 1:
        v = cv2.inRange(cv2.subtract(w[1:], u[:-1]), 1, 16)
        v >>= 7
        both = cv2.copyMakeBorder(v, 1, 1, 0, 0, cv2.BORDER_REPLICATE)
        count = cv2.add(count, cv2.add(both[:-1], both[1:]))
    return cv2.compare(count, min_votes, cv2.CMP_GE)


def _relax(raw: np.ndarray, candidate: np.ndarray) -> np.ndarray:
    """One pass: an unsegmented pixel joins its value's class if >= 2 neighbours hold it."""
    padded = cv2.copyMakeBorder(raw, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)
    rows, cols = raw.shape
    agree = np.zeros(raw.shape, np.uint8)
    for dy, dx in ((0, 1), (2, 1), (1, 0), (1, 2)):
        same = cv2.compare(padded[dy : dy + rows, dx : dx + cols], candidate, cv2.CMP_EQ)
        same >>= 7
        agree += same
    # Where the candidate is 0 (no class) joining changes nothing, so no test is needed.
    join = cv2.bitwise_and(cv2.compare(raw, 0, cv2.CMP_EQ), cv2.compare(agree, 2, cv2.CMP_GE))
    return cv2.bitwise_or(raw, cv2.bitwise_and(candidate, join))


def segment_plane(
    plane: np.ndarray,
    params: VisionParams,
    mask: np.ndarray | None = None,
    offset: int = 0,
    *,
    rotated: bool = False,
) -> Segmentation:
    """Segment one 8-bit plane into at most 8 classes plus unsegmented pixels.

    Parameters
    ----------
    plane : (M, N) uint8 ndarray
        Not modified.
    params : VisionParams
    mask : (M, N) bool ndarray, optional
        Pixels outside the mask are never labelled and their pairs are not counted.
    offset : int
        Segment (plane + offset) mod 256 instead (hue rotation); recorded in the result.
    rotated : bool
        ``plane`` is already (value + offset) mod 256: segmented as it is, the offset only
        recorded (the caller made the rotated plane and needs no second copy of it).

    Returns
    -------
    Segmentation

    Examples
    --------
    >>> from cyborg.daemon.vision.params import PAPER
    >>> plane = np.full((20, 40), 40, np.uint8)
    >>> plane[:, 30:] = 200
    >>> plane[:, 10] = 120                        # a one-pixel line is no region
    >>> seg = segment_plane(plane, PAPER)
    >>> [(c.center, c.area) for c in seg.classes]
    [(40, 580), (200, 200)]
    >>> seg.labels[5, [0, 10, 29, 30, 39]].tolist()
    [1, 0, 1, 2, 2]
    """
    if plane.ndim != 2:
        raise ValueError(f"expected an (M, N) plane, got shape {plane.shape}")
    if plane.dtype != np.uint8:
        raise ValueError(f"expected uint8, got {plane.dtype}")
    # numpy uint8 addition wraps modulo 256, which is the hue rotation we want.
    coded = plane if rotated or offset % 256 == 0 else plane + np.uint8(offset % 256)
    hist = cooccurrence_histogram(coded, mask, params.cooc_max_pairs)
    prof, peaks = diagonal_classes(hist, params)
    if not peaks:
        labels = np.zeros(plane.shape, np.uint8)
        return Segmentation(labels, (), hist, offset % 256, _values(coded, params), prof)
    order, u_lut = _value_tables(peaks, hist.sum(axis=1))
    classes = [peaks[i] for i in order]
    raw, areas = _label(coded, u_lut, mask, params, len(classes))
    ranked_ids = sorted(
        (i for i in range(len(classes)) if areas[i] > 0),
        key=lambda i: (-areas[i], -classes[i].height, classes[i].center),
    )
    to_rank = np.zeros(256, np.uint8)
    for rank, i in enumerate(ranked_ids, start=1):
        to_rank[i + 1] = rank
    if ranked_ids != list(range(len(classes))):
        cv2.LUT(raw, to_rank, dst=raw)
    ranked = tuple(dataclasses.replace(classes[i], area=areas[i]) for i in ranked_ids)
    return Segmentation(raw, ranked, hist, offset % 256, _values(coded, params), prof)


def _values(coded: np.ndarray, params: VisionParams) -> np.ndarray | None:
    """The coded plane, kept in the segmentation only where it is read (``value_rarity``): a
    rotated hue is a plane-sized copy."""
    return coded if params.value_rarity > 0 else None


def _label(
    coded: np.ndarray, u_lut: np.ndarray, mask: np.ndarray | None, params: VisionParams, k: int
) -> tuple[np.ndarray, list[int]]:
    """Label every pixel with its class id 1..``k`` (0: unsegmented) and count each class.

    The vote and each relaxation pass read a pixel's 4 neighbours only, so a band of rows
    labelled with ``1 + relax_passes`` rows of the image on each side holds exactly the
    labels of the whole image: the band's temporaries (about 8 bytes per pixel) stay a
    band's, whatever the image's size.
    """
    rows, cols = coded.shape
    labels = np.empty((rows, cols), np.uint8)
    areas = [0] * k
    halo = 1 + params.relax_passes
    step = max(1, BAND_PIXELS // max(cols, 1))
    for r0 in range(0, rows, step):
        r1 = min(rows, r0 + step)
        top, bottom = max(0, r0 - halo), min(rows, r1 + halo)
        band = _label_band(
            coded[top:bottom], u_lut, None if mask is None else mask[top:bottom], params
        )
        labels[r0:r1] = band[r0 - top : r1 - top]
        # One pass counts every class (float32 counts are exact: a band is < 2^24 pixels).
        counts = cv2.calcHist([labels[r0:r1]], [0], None, [k + 1], [0, k + 1]).ravel()
        for c in range(k):
            areas[c] += int(counts[c + 1])
    return labels, areas


def _label_band(
    coded: np.ndarray, u_lut: np.ndarray, mask: np.ndarray | None, params: VisionParams
) -> np.ndarray:
    """Class ids of a band of rows, exact but for the ``1 + relax_passes`` rows at each edge
    that is not the image's."""
    u = cv2.LUT(coded, u_lut)
    ok = _vote(u, params.min_votes)
    if mask is not None:
        ok[~mask] = 0
    # Every pixel's candidate class is its value's class, the top bits of its u code; the
    # labelled pixels keep it.
    candidate = np.right_shift(u, 5) + np.uint8(1)
    raw = cv2.bitwise_and(candidate, ok)
    if params.relax_passes:
        has_class = cv2.compare(u, _NONE, cv2.CMP_NE)
        if mask is not None:
            has_class[~mask] = 0
        candidate = cv2.bitwise_and(candidate, has_class)
        for _ in range(params.relax_passes):
            raw = _relax(raw, candidate)
    return raw
