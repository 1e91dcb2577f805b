"""Interest map: the weighted sum of the uncommon maps, Gaussian-blurred.

B is read as the full width at half maximum (``blur_mode="fwhm"``, sigma = B / 2.355) or as
the Gaussian sigma, in analysed-image pixels, or as a fraction of the image diagonal
(``blur_fraction``). The seed does not say; on its own case (a 108x192 cliff with wet stains
of 1-2 % of the image, ~10 px across) the sigma reading smears each stain below the
bed-scale structure around it, while the FWHM reading keeps it (``bench.quality``, seed).
Heights count from the image's median, and the blur counts the outside of the frame as that
typical level.

Optionally (``isotropy``) the blurred interest is scaled by the roundness of its
surroundings, which takes long ledge shadows off the top of the list, and (``wide_scale``)
the uncommon map is also blurred several times wider and each cell keeps its better scale,
so a compact area of rare colour tens of pixels across scores as a whole rather than at its
textured rim. The points are the map's peaks (``peaks.find_points``).

Speed without approximation worth the name: a sigma-B blur removes everything above
~1/(2 pi B) cycles/px, so the sum map is first averaged over f x f blocks (f a power of two
<= B / 1.5) and blurred on that small grid (``grid``). Peaks are found there and refined to
sub-pixel positions; the full-resolution map is produced only when asked for (products).
``exact_blur=True`` turns this off.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from .cooccurrence import BAND_PIXELS, Segmentation
from .grid import block_means, expand, grid_blur
from .kernels import kernel
from .order import median, percentiles
from .params import VisionParams
from .uncommon import uncommon_map

__all__ = ["InterestMap", "InterestPoint", "fuse", "interest_map", "summed_uncommon"]


@dataclass(frozen=True)
class InterestMap:
    """The blurred interest map, held on a grid ``factor`` times coarser than the image."""

    grid: np.ndarray
    """(m, n) float32, in uncommon units above the image's median (up to 24 for unit
    weights)."""
    factor: int
    shape: tuple[int, int]
    """(M, N) of the analysed image."""
    blurred: np.ndarray | None = None
    """The map before the last roundness, when ``grid`` is reshaped by it: points are
    located on it (a ring of roundness must not split one target into two)."""
    plain: np.ndarray | None = None
    """The blurred interest before any roundness: which peaks are one target is judged on
    it. Roundness is a score, not an extent; on a wide flat patch it is noise, and its
    ripples split one lichen or one lens into several peaks."""
    lines: np.ndarray | None = None
    """What the line term added to ``grid`` (weighted), on the same grid: the explanations
    read it at each point."""

    def full(self) -> np.ndarray:
        """The map at the analysed image's resolution, (M, N) float32."""
        return expand(self.grid, self.factor, self.shape)


@dataclass(frozen=True)
class InterestPoint:
    """One interest point, in analysed-image pixels (x = column, y = row)."""

    rank: int
    x: float
    y: float
    score: float
    radius: float = 0.0
    """The size of what the point found (analysed pixels): no other point lies within it."""
    target: bool = True
    """False when its score cannot be told from the view's background
    (``peaks.mark_background``): "no further target", kept and marked."""


def _factor(sigma: float, shape: tuple[int, int], exact: bool) -> int:
    if exact:
        return 1
    f = 1
    while f * 2 <= sigma / 1.5 and min(shape) >= f * 2 * 4:
        f *= 2
    return f


def summed_uncommon(
    segs: tuple[Segmentation, ...], params: VisionParams, maps: list[np.ndarray] | None = None
) -> np.ndarray:
    """The weighted sum of the H, S, I uncommon maps (given, or made here), (M, N) float32."""
    if maps is None:
        maps = [uncommon_map(seg, params) for seg in segs]
    total = np.zeros(segs[0].labels.shape, np.float32)
    for umap, weight in zip(maps, params.plane_weights, strict=True):
        if weight:
            cv2.scaleAdd(umap, weight, total, dst=total)
    return total


def _summed_means(
    segs: tuple[Segmentation, ...], params: VisionParams, step: int, f: int
) -> tuple[np.float32, np.ndarray]:
    """The median of :func:`summed_uncommon` on the lattice of every ``step``-th pixel and its
    f x f block means, value for value, from bands of rows (each pixel's sum is its own
    labels'; a band starts on the lattice and on a block, and the last keeps the rows the
    frame's reflected padding reads)."""
    rows, cols = segs[0].labels.shape
    unit = math.lcm(step, f)
    height = unit * max(1, BAND_PIXELS // (unit * max(cols, 1)))
    means = np.empty((-(-rows // f), -(-cols // f)), np.float32)
    lattice = []
    r0 = 0
    while r0 < rows:
        r1 = rows if rows - r0 < height + f else r0 + height
        band = summed_uncommon(tuple(seg.window(np.s_[r0:r1, :]) for seg in segs), params)
        lattice.append(band[::step, ::step].copy())  # not a view: the band goes
        means[r0 // f : -(-r1 // f)] = block_means(band, f)
        r0 = r1
    return np.float32(median(np.concatenate(lattice))), means


def interest_map(
    segs: tuple[Segmentation, ...],
    params: VisionParams,
    total: np.ndarray | None = None,
    texture: np.ndarray | None = None,
    *,
    prior: np.ndarray | None = None,
    line: np.ndarray | None = None,
) -> InterestMap:
    """Sum the H, S, I uncommon maps with their weights and blur with sigma B.

    Parameters
    ----------
    segs : tuple of three Segmentation
        H, S, I segmentations of the same image.
    params : VisionParams
        Uses ``plane_weights``, the blur fields, ``isotropy``, ``exact_blur`` and
        the uncommon fields.

    total : (M, N) float32 ndarray, optional
        :func:`summed_uncommon` of ``segs``, when the caller already has it; else it is
        summed a band of rows at a time and never held whole.
    texture : (M, N) float32 ndarray, optional
        ``texture.texture_rarity`` of the image, fused in with ``texture_weight`` (:func:`fuse`).
    prior : (M, N) float32 ndarray, optional
        Weights (typically 0..1) the interest is multiplied by where peaks are picked: what
        an earlier look at the same ground already judged (memory across stations). Patches
        keep their extent from the unweighted map.
    line : (M, N) float32 ndarray, optional
        Line rarity (``lines``: squared robust bar contrast, shade taken out), added with
        ``line_weight`` after every roundness: to the map peaks are picked on, the one they
        are located on and the one that says which peaks are one target, so a vein is a
        target of its own.

    Returns
    -------
    InterestMap

    Examples
    --------
    >>> from cyborg.daemon.vision.segment import segment_plane
    >>> from cyborg.daemon.vision.params import PAPER
    >>> plane = np.full((60, 60), 40, np.uint8)
    >>> plane[25:35, 25:35] = 200
    >>> seg = segment_plane(plane, PAPER.replace(blur_mode="sigma"))
    >>> imap = interest_map((seg, seg, seg), PAPER.replace(blur_mode="sigma"))
    >>> imap.factor, imap.grid.shape, imap.full().shape
    (4, (15, 15), (60, 60))
    >>> bool(imap.full()[30, 30] > imap.full()[5, 5])
    True
    """
    rows, cols = segs[0].labels.shape if total is None else total.shape
    # Heights count from the typical level (the median, on a lattice of <= 2^18 pixels), and
    # outside the frame counts as typical rock.
    step = max(1, math.isqrt(rows * cols >> 18))
    sigma = params.sigma((rows, cols))
    f = _factor(sigma, (rows, cols), params.exact_blur)
    if total is None:  # summed a band at a time: the full-size float sum is never made
        typical, means = _summed_means(segs, params, step, f)
    else:
        typical, means = np.float32(median(total[::step, ::step])), block_means(total, f)
    base = means - typical
    blurred = _blur(base, sigma, f)
    uncommon = blurred
    grid = plain = blurred
    if params.isotropy > 0:
        grid = blurred * _roundness(blurred, sigma / f, params.isotropy)
    if texture is not None and params.texture_weight > 0:
        rare = _blur(
            block_means(texture, f) - median(texture[::step, ::step]),
            sigma * params.texture_blur,
            f,
        )
        fused = fuse(grid, rare, params.texture_weight)
        plain = fused if plain is grid else fuse(plain, rare, params.texture_weight)
        blurred = grid = fused
        if params.fused_isotropy > 0:
            grid = fused * _roundness(fused, sigma / f, params.fused_isotropy)
    if params.wide_scale > 0:
        on_fused = texture is not None and params.texture_weight > 0
        wide = _wide(base, uncommon if on_fused else None, sigma, f, params)
        # Each cell keeps its better scale; maps that are one array stay one.
        higher = {id(m): cv2.max(m, wide) for m in (grid, blurred, plain)}
        grid, blurred, plain = (higher[id(m)] for m in (grid, blurred, plain))
    lines = None
    if line is not None and params.line_weight > 0:
        # Typical rock is on no line (its rarity is 0 at the median and below: ``lines``).
        lines = _blur(block_means(line, f), sigma, f)
        lines = params.line_weight * _unit(lines, _NO_LINE)
        # The same lines on each map; maps that are one array stay one.
        same = (blurred is grid, plain is grid, plain is blurred)
        grid = grid + lines
        blurred = grid if same[0] else blurred + lines
        plain = grid if same[1] else blurred if same[2] else plain + lines
    if prior is not None:
        grid = grid * block_means(prior.astype(np.float32, copy=False), f)
    return InterestMap(
        grid,
        f,
        (rows, cols),
        None if grid is blurred else blurred,
        None if plain is blurred else plain,
        lines,
    )


def fuse(uncommon: np.ndarray, texture: np.ndarray, weight: float) -> np.ndarray:
    """uncommon + weight x texture, each first put on one scale: 0 at its median, 1 at its
    99.5th percentile (where the few rarest areas start), so the weight is a share whatever
    the units (uncommon values; squared Mahalanobis distances). A texture spread under
    ``_NO_TEXTURE`` is rounding, not contrast, and is not stretched to 1."""

    return cv2.scaleAdd(_unit(texture, _NO_TEXTURE), weight, _unit(uncommon, 1e-6))


def _unit(grid: np.ndarray, floor: float) -> np.ndarray:
    """``grid`` with its median at 0 and its 99.5th percentile at 1, the spread between
    them taken as at least ``floor`` (less is no contrast worth a point)."""
    low, high = percentiles(grid, (50.0, 99.5))
    return (grid - np.float32(low)) * np.float32(1.0 / max(high - low, floor))


_NO_TEXTURE = 0.1
"""Squared robust standard deviations: blurred texture rarity that spreads less than this
between its median and its 99.5th percentile has no contrast worth a point (a flat image
gives ~1e-9 of float rounding)."""
_NO_LINE = 20.0
"""Squared robust standard deviations of bar contrast, blurred with sigma B: a view whose
blurred line rarity spreads less than this between its median and its 99.5th percentile
holds no line worth a whole unit of interest: views with no target spread a few, views
with a vein tens to hundreds."""


def _wide(
    base: np.ndarray, fine: np.ndarray | None, sigma: float, f: int, params: VisionParams
) -> np.ndarray:
    """The uncommon grid ``base`` blurred at ``wide_scale`` x ``sigma`` and scaled by its
    roundness; with ``fine`` (the uncommon map at sigma, when texture is fused in) on the
    fused map's scale: ``fine``'s median at 0, its 99.5th percentile at 1 + ``texture_weight``.

    Texture rarity is a fine-scale property: it marks a wide target's rim, not its inside,
    while the bed contacts, thin beds and shadow ends of a layered view are rare texture all
    along. A compact area of rare colour tens of pixels across then loses to them on the
    fused map though it is the most uncommon thing in view; blurred at its own scale it is
    a cap as high as a small target rare in both colour and texture (hence the weight),
    and a thin bed or a speck, spread over the wider blur, is not. Roundness (``isotropy``,
    at twice this blur) keeps wide beds and long shadows down.
    """
    wide_sigma = sigma * params.wide_scale
    wide = _blur(base, wide_sigma, f)
    if fine is not None:
        low, high = percentiles(fine, (50.0, 99.5))
        scale = (1.0 + params.texture_weight) / max(float(high - low), 1e-6)
        wide = (wide - np.float32(low)) * np.float32(scale)
    if params.isotropy > 0:
        wide = wide * _roundness(wide, wide_sigma / f, params.isotropy)
    return wide


def _blur(grid: np.ndarray, sigma: float, f: int) -> np.ndarray:
    """``grid.grid_blur`` with the outside of the frame counted as 0 (the typical level, once
    the median is taken off), not as a mirror image: a patch cut by the frame is only partly
    seen and scores for what is seen; mirrored, a half patch at the border would score as a
    whole one."""
    return grid_blur(grid, sigma, f, cv2.BORDER_CONSTANT)


def _roundness(blurred: np.ndarray, sigma: float, share: float) -> np.ndarray:
    """1 - share + share x iso, iso = lambda_max / lambda_min where the map at twice the
    blur curves down in every direction (a cap): 1 on a round patch, 0 along a ridge or on a
    slope, whatever the height. Curvature under ``_FLAT`` of the map's strongest counts as
    flat, so a wide flat top is round instead of noise."""
    wider = cv2.GaussianBlur(blurred, (0, 0), math.sqrt(3.0) * sigma)
    border = cv2.BORDER_REFLECT_101
    lxx = cv2.Sobel(wider, cv2.CV_32F, 2, 0, ksize=3, scale=0.25, borderType=border)
    lyy = cv2.Sobel(wider, cv2.CV_32F, 0, 2, ksize=3, scale=0.25, borderType=border)
    lxy = cv2.Sobel(wider, cv2.CV_32F, 1, 1, ksize=3, scale=0.25, borderType=border)
    radius = cv2.magnitude(cv2.subtract(lxx, lyy) * 0.5, lxy)
    return _isotropy(lxx, lyy, radius, _FLAT, share)


@kernel
def _isotropy(
    lxx: np.ndarray, lyy: np.ndarray, radius: np.ndarray, flat: float, share: float
) -> np.ndarray:
    """:func:`_roundness` from the Hessian (its diagonal, and the radius of its eigenvalues
    about their mean) in two passes (the strongest downward curvature, then each cell):
    float32 arithmetic, operation for operation as the whole-array expression of it."""
    xx, yy, rr = lxx.ravel(), lyy.ravel(), radius.ravel()  # OpenCV's: contiguous
    half = np.float32(0.5)
    strongest = np.inf  # the least lambda_min
    for i in range(len(xx)):
        strongest = min(strongest, (xx[i] + yy[i]) * half - rr[i])
    eps = np.float32(flat * max(-float(np.float32(strongest)), 0.0))
    keep, weight, steep = np.float32(1.0 - share), np.float32(share), np.float32(-1e-12)
    out = np.empty_like(xx)
    for i in range(len(xx)):
        mean = (xx[i] + yy[i]) * half
        lmin = mean - rr[i]
        iso = np.float32(0.0)
        if lmin < eps:
            iso = (mean + rr[i] - eps) / min(lmin - eps, steep)
            iso = min(max(iso, np.float32(0.0)), np.float32(1.0))
        out[i] = keep + weight * iso
    return out.reshape(lxx.shape)


_FLAT = 0.1
"""Curvature, as a share of the map's strongest, under which a top counts as flat. On a wide
flat patch (a lens, a lichen) the curvatures' ratio is noise, and its ripples split the patch
into peaks that move the best point along it from one look to the next."""
