"""The co-occurrence histogram of one 8-bit plane and its classes (after Haddon & Boyce 1990).

Pairs of 4-neighbours (a, b) are counted symmetrically in a 256x256 histogram. Pixels inside
uniform regions give pairs near the diagonal, so each region type is a peak on the diagonal;
pairs across boundaries fall off it. A *class* is a diagonal peak (at most 8) and a region of
(value, neighbour value) space around it, of one of two shapes (``class_shape``):

* ``block``: Haddon & Boyce's reading. The diagonal profile's maxima are ranked by
  persistence (how far the profile must fall before a maximum joins a higher one), the
  strongest are kept, and each class owns the block of values between the valleys that
  separate it from its neighbours. Blocks tile the value axis, so inside a region every pair
  lies in its block and only pairs across a boundary fall outside: regions are coherent and
  just their boundaries stay unsegmented.
* ``disc``: the disc of radius r around (g, g), r the peak's half-width at half-maximum
  times ``radius_scale``, cut to the values nearer to g than to any other peak.

Pixels are labelled with these classes by ``segment.segment_plane``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import cv2
import numpy as np

from .kernels import kernel
from .params import VisionParams

__all__ = [
    "BAND_PIXELS",
    "PlaneClass",
    "Segmentation",
    "cooccurrence_histogram",
    "diagonal_classes",
    "find_classes",
]

BAND_PIXELS = 1 << 16
"""Pixels per band of rows where a whole-image computation that is per pixel (or reads a
pixel's neighbours) is done a band at a time, so its temporaries are a band's, not the
image's."""


@dataclass(frozen=True)
class PlaneClass:
    """One class of a plane: a peak on the co-occurrence diagonal and its values."""

    center: int
    """Grey value of the diagonal peak, in the (possibly hue-rotated) segmented coding."""
    radius: int
    """Disc radius; for a block, the larger distance from the peak to a block end."""
    height: float
    """Height of the smoothed diagonal profile at the peak."""
    area: int = 0
    """Number of pixels labelled with this class."""
    lo: int = -1
    hi: int = -1
    """Values lo..hi (segmented coding) form the class's block; -1: a disc."""

    @property
    def is_block(self) -> bool:
        return self.lo >= 0

    @property
    def span(self) -> tuple[int, int]:
        """The values the class can hold (its block, or its disc's extent), inclusive."""
        if self.is_block:
            return self.lo, self.hi
        return max(0, self.center - self.radius), min(255, self.center + self.radius)


@dataclass(frozen=True)
class Segmentation:
    """Result of ``segment.segment_plane``."""

    labels: np.ndarray
    """(M, N) uint8: 0 = unsegmented, k = 1..K the class of area rank k (1 = largest)."""
    classes: tuple[PlaneClass, ...]
    """Class k is ``classes[k - 1]``; areas are non-increasing."""
    histogram: np.ndarray
    """(256, 256) float32 symmetric pair counts (before smoothing), for plots."""
    offset: int = 0
    """The plane was segmented as (value + offset) mod 256 (hue rotation)."""
    values: np.ndarray | None = None
    """(M, N) uint8: the plane in segmented coding (after the rotation)."""
    profile: np.ndarray | None = None
    """(256,) float64: the smoothed diagonal profile, the density of region interiors."""

    @property
    def k(self) -> int:
        return len(self.classes)

    def window(self, box: tuple[slice, slice]) -> Segmentation:
        """The same classes over a window of the image (its ``labels`` and ``values`` there):
        what each pixel's label alone decides, as its uncommon value, is the same as on the
        whole image."""
        values = None if self.values is None else self.values[box]
        return dataclasses.replace(self, labels=self.labels[box], values=values)

    def original_value(self, coded: int) -> int:
        """Map a value in segmented coding back to the plane's own coding."""
        return (coded - self.offset) % 256


def cooccurrence_histogram(
    plane: np.ndarray, mask: np.ndarray | None = None, max_pairs: int = 1 << 22
) -> np.ndarray:
    """Count 4-neighbour value pairs of a plane, symmetrically.

    Parameters
    ----------
    plane : (M, N) uint8 ndarray
    mask : (M, N) bool ndarray, optional
        Only pairs whose two pixels are both in the mask are counted.
    max_pairs : int
        Above this many pairs, rows are taken on a regular lattice (a deterministic
        estimate; the histogram is a density and a few million pairs resolve it).

    Returns
    -------
    (256, 256) float32 ndarray
        ``hist[a, b]`` counts pairs (a, b) and (b, a); the sum is twice the pairs used.

    Examples
    --------
    >>> plane = np.array([[1, 1], [1, 2]], np.uint8)
    >>> h = cooccurrence_histogram(plane)
    >>> int(h[1, 1]), int(h[1, 2]), int(h[2, 1]), int(h.sum())
    (4, 2, 2, 8)
    """
    if plane.ndim != 2:
        raise ValueError(f"expected an (M, N) plane, got shape {plane.shape}")
    if plane.dtype != np.uint8:
        raise ValueError(f"expected uint8, got {plane.dtype}")
    rows, cols = plane.shape
    total = rows * (cols - 1) + (rows - 1) * cols
    step = max(1, -(-total // max_pairs))
    # Row-strided views go to OpenCV without copies: only the element stride must be 1.
    runs = (
        (np.s_[::step, :-1], np.s_[::step, 1:]),  # horizontal pairs
        (np.s_[:-1:step], np.s_[1::step]),  # vertical pairs
    )
    m8 = None if mask is None else mask.view(np.uint8)
    hist = np.zeros((256, 256), np.float32)
    for first, second in runs:
        if plane[first].size == 0:
            continue
        both = None if m8 is None else cv2.bitwise_and(m8[first], m8[second])
        hist = cv2.calcHist(
            [plane[first], plane[second]], [0, 1], both, [256, 256], [0, 256, 0, 256], hist, True
        )
    return hist + hist.T


def _diagonal_profile(smooth: np.ndarray, band: int) -> np.ndarray:
    prof = np.zeros(256, np.float64)
    for d in range(-band, band + 1):
        diag = np.diagonal(smooth, offset=d).astype(np.float64)
        if d >= 0:
            prof[: 256 - d] += diag
        else:
            prof[-d:] += diag
    return prof


def _half_width(prof: np.ndarray, g: int) -> float:
    """Half-width at half-maximum of the peak at g; a side that runs into a higher peak
    before falling to half does not count, a side that runs off the scale ends there."""
    half = prof[g] / 2.0
    widths = []
    for direction in (-1, 1):
        x = g
        climbed = False
        while 0 <= x + direction < 256 and prof[x + direction] > half:
            if prof[x + direction] > prof[g]:
                climbed = True
                break
            x += direction
        if not climbed:
            widths.append(abs(x - g) + 0.5)
    return min(widths) if widths else 0.0


def find_classes(hist: np.ndarray, params: VisionParams) -> tuple[PlaneClass, ...]:
    """Find the region classes of a co-occurrence histogram (peaks on its diagonal).

    Parameters
    ----------
    hist : (256, 256) float ndarray
        Symmetric pair counts from :func:`cooccurrence_histogram`.
    params : VisionParams
        Uses ``class_shape``, ``cooc_sigma``, ``diag_band``, ``max_classes``,
        ``min_class_fraction``, and ``min_persistence`` (blocks) or ``radius_scale``,
        ``radius_min`` and ``radius_max`` (discs).

    Returns
    -------
    tuple of PlaneClass
        At most ``max_classes`` classes, highest peak first, ``area`` still 0.

    Examples
    --------
    >>> from cyborg.daemon.vision.params import PAPER
    >>> plane = np.repeat(np.array([[40] * 30 + [200] * 10], np.uint8), 20, axis=0)
    >>> [(c.center, c.lo, c.hi) for c in find_classes(cooccurrence_histogram(plane), PAPER)]
    [(40, 0, 120), (200, 121, 255)]
    >>> disc = PAPER.replace(class_shape="disc")
    >>> [(c.center, c.radius) for c in find_classes(cooccurrence_histogram(plane), disc)]
    [(40, 3), (200, 3)]
    """
    return diagonal_classes(hist, params)[1]


def diagonal_classes(
    hist: np.ndarray, params: VisionParams
) -> tuple[np.ndarray, tuple[PlaneClass, ...]]:
    """The smoothed diagonal profile of ``hist`` and the classes found on it
    (:func:`find_classes`): ``segment.segment_plane`` keeps both."""
    prof, smooth = _profile(hist, params)
    return prof, _classes(prof, smooth, params)


def _profile(hist: np.ndarray, params: VisionParams) -> tuple[np.ndarray, np.ndarray]:
    """(diagonal profile, smoothed histogram)."""
    if hist.shape != (256, 256):
        raise ValueError(f"expected a (256, 256) histogram, got {hist.shape}")
    smooth = hist.astype(np.float32)
    if params.cooc_sigma > 0:
        smooth = cv2.GaussianBlur(smooth, (0, 0), params.cooc_sigma)
    return _diagonal_profile(smooth, params.diag_band), smooth


def _classes(prof: np.ndarray, smooth: np.ndarray, params: VisionParams) -> tuple[PlaneClass, ...]:
    if prof.sum() <= 0:
        return ()
    if params.class_shape == "block":
        return _blocks(prof, smooth, params)
    return _discs(prof, params)


def _discs(prof: np.ndarray, params: VisionParams) -> tuple[PlaneClass, ...]:
    mass = prof.sum()
    left = np.concatenate([[-1.0], prof[:-1]])
    right = np.concatenate([prof[1:], [-1.0]])
    maxima = np.flatnonzero((prof > 0) & (prof >= left) & (prof > right))
    spacing = 2 * params.radius_min
    chosen: list[PlaneClass] = []
    for g in sorted(maxima.tolist(), key=lambda v: (-prof[v], v)):
        if any(abs(g - c.center) < spacing for c in chosen):
            continue
        hwhm = _half_width(prof, g) * params.radius_scale
        r = int(np.clip(round(hwhm), params.radius_min, params.radius_max))
        share = prof[max(0, g - r) : g + r + 1].sum() / mass
        if share < params.min_class_fraction:
            continue
        chosen.append(PlaneClass(center=g, radius=r, height=float(prof[g])))
        if len(chosen) == params.max_classes:
            break
    return tuple(chosen)


@kernel
def _persistence(prof: np.ndarray) -> np.ndarray:
    """Each local maximum of a 1-D profile and its persistence: how far the profile falls
    from it before reaching a higher maximum (0-dimensional persistent homology of the
    superlevel sets; the highest maximum gets its full height). ``out[g]`` is the
    persistence of the maximum at g, -1 where there is none.

    Values are visited from the highest down (ties: the lower index first); each joins the
    maximum of its neighbours' regions, and where two regions meet the lower maximum dies.
    """
    n = len(prof)
    out = np.full(n, -1.0)
    owner = np.full(n, -1)
    for i in np.argsort(-prof, kind="mergesort"):  # stable: ties keep the lower index first
        if prof[i] <= 0:
            break
        left = owner[i - 1] if i > 0 else -1
        right = owner[i + 1] if i + 1 < n else -1
        if left < 0 and right < 0:
            owner[i] = i
            continue
        top = left if right < 0 else right
        if left >= 0 and right >= 0 and left != right:
            # The higher maximum (ties: the lower value) lives; the other dies at prof[i].
            high = prof[left] > prof[right] or (prof[left] == prof[right] and left < right)
            top, low = (left, right) if high else (right, left)
            out[low] = prof[low] - prof[i]
            for j in range(n):
                if owner[j] == low:
                    owner[j] = top
        owner[i] = top
    for j in range(n):
        if owner[j] == j and out[j] < 0:  # never died: its full height
            out[j] = prof[j]
    return out


@kernel
def _valleys(prof: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """The last value of the left block between each two successive maxima a < b: the
    middle of the lowest run of the profile between them (the middle run if several)."""
    ends = np.empty(len(centres) - 1, np.int64)
    for c in range(len(centres) - 1):
        a, b = centres[c], centres[c + 1]
        seg = prof[a : b + 1]
        low = seg.min() + 1e-9 * max(seg.max(), 1e-30)
        runs = 0  # runs of values <= low, then the middle one's ends
        inside = False
        for v in seg:
            if v <= low and not inside:
                runs += 1
            inside = v <= low
        want, run, first, last = runs // 2, -1, -1, -1
        inside = False
        for j in range(len(seg)):
            here = seg[j] <= low
            if here and not inside:
                run += 1
                if run == want:
                    first = j
            if here and run == want:
                last = j
            inside = here
        ends[c] = a + (first + last) // 2
    return ends


def _blocks(prof: np.ndarray, smooth: np.ndarray, params: VisionParams) -> tuple[PlaneClass, ...]:
    persistence = _persistence(prof)
    kept = sorted(
        (
            g
            for g in np.flatnonzero(persistence >= 0).tolist()
            if persistence[g] >= params.min_persistence * prof[g]
        ),
        key=lambda g: (-persistence[g], g),
    )[: params.max_classes]
    # A block's mass is the pair count inside its square; light blocks merge into a
    # neighbour (their maximum is dropped and the valleys are drawn again) until all count.
    cum = cv2.integral(smooth, sdepth=cv2.CV_64F)  # cum[i, j] = sum of smooth[:i, :j]
    total = cum[-1, -1]
    while True:
        centres = sorted(kept)
        ends = _valleys(prof, np.array(centres, np.int64)).tolist()
        bounds = list(zip([0, *(e + 1 for e in ends)], [*ends, 255], strict=True))
        masses = [
            cum[hi + 1, hi + 1] - cum[lo, hi + 1] - cum[hi + 1, lo] + cum[lo, lo]
            for lo, hi in bounds
        ]
        lightest = int(np.argmin(masses))
        if len(kept) == 1 or masses[lightest] >= params.min_class_fraction * total:
            break
        kept.remove(centres[lightest])
    by_height = sorted(zip(centres, bounds, strict=True), key=lambda cb: (-prof[cb[0]], cb[0]))
    return tuple(
        PlaneClass(g, max(g - lo, hi - g), float(prof[g]), lo=lo, hi=hi)
        for g, (lo, hi) in by_height
    )
