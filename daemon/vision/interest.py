"""Interest map (weighted sum of the uncommon maps, Gaussian-blurred) and interest points.

B is read as the full width at half maximum (``blur_mode="fwhm"``, sigma = B / 2.355) or as
the Gaussian sigma, in analysed-image pixels, or as a fraction of the image diagonal
(``blur_fraction``). The seed does not say; on its own case (a 108x192 cliff with wet stains
of 1-2 % of the image, ~10 px across) the sigma reading smears each stain below the
bed-scale structure around it, while the FWHM reading keeps it (``bench.quality``, seed).
Heights count from the image's median, and the blur counts the outside of the frame as that
typical level.

Points are peaks at least B apart. With ``valley`` > 0 two peaks are one target unless the
map dips below ``valley`` x the lower peak between them (a persistence test, free of any
size guess), so three points are three targets from a 5 px spot to a patch of 15 % of the
image; each point's radius is the size of its own patch. Optionally (``isotropy``) the
blurred interest is scaled by the roundness of its surroundings, which takes long ledge
shadows off the top of the list; (``wide_scale``) the uncommon map is also blurred several
times wider and each cell keeps its better scale, so a compact area of rare colour tens of
pixels across scores as a whole rather than at its textured rim; and (``bands``, ``frame``)
each peak is judged by its whole patch, so beds, the skyline and slivers the frame cuts are
discounted.

Speed without approximation worth the name: a sigma-B blur removes everything above
~1/(2 pi B) cycles/px, so the sum map is first averaged over f x f blocks (f a power of two
<= B / 1.5) and blurred on that small grid (``grid``). Peaks are found there and refined to
sub-pixel positions; the full-resolution map is produced only when asked for (products).
``exact_blur=True`` turns this off.
"""

from __future__ import annotations

import heapq
import math
from dataclasses import dataclass

import cv2
import numpy as np

from .cooccurrence import Segmentation
from .grid import block_means, expand, grid_blur
from .params import VisionParams
from .uncommon import uncommon_map

__all__ = ["InterestMap", "InterestPoint", "find_points", "fuse", "interest_map", "summed_uncommon"]


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
        :func:`summed_uncommon` of ``segs``, when the caller already has it.
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
    >>> from cyborg.daemon.vision.cooccurrence import segment_plane
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
    if total is None:
        total = summed_uncommon(segs, params)
    rows, cols = total.shape
    # Heights count from the typical level (the median, on a lattice of <= 2^18 pixels), and
    # outside the frame counts as typical rock.
    step = max(1, math.isqrt(rows * cols >> 18))
    typical = np.float32(np.median(total[::step, ::step]))
    sigma = params.sigma((rows, cols))
    f = _factor(sigma, (rows, cols), params.exact_blur)
    base = block_means(total, f) - typical
    blurred = _blur(base, sigma, f)
    uncommon = blurred
    grid = plain = blurred
    if params.isotropy > 0:
        grid = blurred * _roundness(blurred, sigma / f, params.isotropy)
    if texture is not None and params.texture_weight > 0:
        rare = _blur(
            block_means(texture, f) - np.median(texture[::step, ::step]),
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
    low, high = np.percentile(grid, (50.0, 99.5))
    return (grid - np.float32(low)) * np.float32(1.0 / max(high - low, floor))


_NO_TEXTURE = 0.1
"""Squared robust standard deviations: blurred texture rarity that spreads less than this
between its median and its 99.5th percentile has no contrast worth a point (a flat image
gives ~1e-9 of float rounding)."""
_NO_LINE = 20.0
"""Squared robust standard deviations of bar contrast, blurred with sigma B: a view whose
blurred line rarity spreads less than this between its median and its 99.5th percentile
holds no line worth a whole unit of interest. At the 0.13 MP working size (sigma 4.3 px) that
spread is 2-7 (20th to 80th percentile of scenes) in views with no target, 10-126 (median 41)
among the held-out generator's veins and 97-251 among ours. On tuning seeds 1000-1119, against
60: held-out veins top-1 / any of 3 80.8 / 90.8 -> 83.3 / 93.3 %, no-target decoy@1 / repeat@1
19.2 / 72.5 -> 17.5 / 77.5 %, large targets' distinct@3 100 -> 97.5 %; 10 was within two scenes
of 20 everywhere."""


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
    at twice this blur) keeps wide beds and long shadows down. On tuning scenes (seeds
    1000-1119) ``wide_scale`` 4 took large targets' top-1 from 92.5 to 95.8 % (held-out generator
    83.3 -> 94.2), for tiny spots 95.8 -> 94.2 % and no-target repeat@1 88.3 -> 85.8 (held out
    78.3 -> 76.7); 3 and 2 were within a scene or two on large targets and lost more views with no
    target; a centre-surround (the wide blur less one twice as wide) found no large target more.
    Pooled real top-1 / any of 3 64.3 / 81.6 -> 63.7 / 80.1 %: of the nine crack and tile images
    whose points changed, two cracks lost first place (to a speck, and to the frame's edge) and on
    a tile a broad shading took the third point, while three cracks gained a point.
    """
    wide_sigma = sigma * params.wide_scale
    wide = _blur(base, wide_sigma, f)
    if fine is not None:
        low, high = np.percentile(fine, (50.0, 99.5))
        scale = (1.0 + params.texture_weight) / max(float(high - low), 1e-6)
        wide = (wide - np.float32(low)) * np.float32(scale)
    if params.isotropy > 0:
        wide = wide * _roundness(wide, wide_sigma / f, params.isotropy)
    return wide


def _blur(grid: np.ndarray, sigma: float, f: int) -> np.ndarray:
    """``grid.grid_blur`` with the outside of the frame counted as 0 (the typical level, once
    the median is taken off), not as a mirror image: a patch cut by the frame is only partly
    seen and scores for what is seen. Mirrored, a half patch at the border scored as a whole
    one, and vignetted frame edges drew 55-90 % of the best points on three real sets whose
    targets lie there 8-25 % of the time."""
    return grid_blur(grid, sigma, f, cv2.BORDER_CONSTANT)


def _curvatures(smooth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The Hessian's eigenvalues (larger, smaller) at every cell of a smooth map."""
    border = cv2.BORDER_REFLECT_101
    lxx = cv2.Sobel(smooth, cv2.CV_32F, 2, 0, ksize=3, scale=0.25, borderType=border)
    lyy = cv2.Sobel(smooth, cv2.CV_32F, 0, 2, ksize=3, scale=0.25, borderType=border)
    lxy = cv2.Sobel(smooth, cv2.CV_32F, 1, 1, ksize=3, scale=0.25, borderType=border)
    radius = cv2.magnitude(cv2.subtract(lxx, lyy) * 0.5, lxy)
    mean = cv2.add(lxx, lyy) * 0.5
    return mean + radius, mean - radius


def _roundness(blurred: np.ndarray, sigma: float, share: float) -> np.ndarray:
    """1 - share + share x iso, iso = lambda_max / lambda_min where the map at twice the
    blur curves down in every direction (a cap): 1 on a round patch, 0 along a ridge or on a
    slope, whatever the height. Curvature under ``_FLAT`` of the map's strongest counts as
    flat, so a wide flat top is round instead of noise."""
    wider = cv2.GaussianBlur(blurred, (0, 0), math.sqrt(3.0) * sigma)
    lmax, lmin = _curvatures(wider)
    eps = np.float32(_FLAT * max(float(-lmin.min()), 0.0))
    iso = np.where(
        lmin < eps, np.clip((lmax - eps) / np.minimum(lmin - eps, -1e-12), 0.0, 1.0), 0.0
    )
    return (1.0 - share + share * iso).astype(np.float32)


_FLAT = 0.1
"""Curvature, as a share of the map's strongest, under which a top counts as flat. On a wide
flat patch (a lens, a lichen) the curvatures' ratio is noise, and its ripples split the patch
into peaks that moved the best point along it from one look to the next: repeat@1 on large
targets 85.8 -> 92.5 % (86.7 -> 95.0 on held-out scenes), for tiny top-1 -0.8 (-1.7) and
pooled real top-1 -0.9 (``bench.quality``, ``bench.real``)."""


def _refine(grid: np.ndarray, r: int, c: int) -> tuple[float, float]:
    """Sub-cell peak position by a parabola through the 3 samples on each axis."""

    def offset(a: float, b: float, d: float) -> float:
        den = a - 2.0 * b + d
        return 0.0 if den >= 0 else float(np.clip(0.5 * (a - d) / den, -0.5, 0.5))

    rows, cols = grid.shape
    dy = offset(grid[r - 1, c], grid[r, c], grid[r + 1, c]) if 0 < r < rows - 1 else 0.0
    dx = offset(grid[r, c - 1], grid[r, c], grid[r, c + 1]) if 0 < c < cols - 1 else 0.0
    return r + dy, c + dx


def find_points(imap: InterestMap, params: VisionParams) -> list[InterestPoint]:
    """Pick the ``top_n`` highest peaks, each at least ``separation`` from the others and,
    with ``valley`` > 0, on a patch of its own.

    A peak is a local maximum over a (2 d + 1)^2 window (d = separation) that stands above
    the map's minimum and above 0 (the image's typical level): a flat map (no contrast)
    yields no points, and nothing commoner than typical is one. A peak's patch is the
    connected part of the map above ``valley`` x its height over the map's median that
    holds it, on the map before any roundness (``plain``); a peak whose patch holds a chosen
    point, or which settles within a chosen point's radius, is that point's target again. A
    point's radius is that of a disc of the area above half its height (``_EXTENT``), and its
    position the centre of a ring (``_ring``, looked for down to ``_RING_LEVELS``), else the
    centre of mass of that patch (of its top, ``_TOP``, where a crescent's centre falls
    outside it) settled by a mean shift at the point's own radius (``_settle``); without
    ``valley`` they are the separation and the refined peak.
    Extents and positions are taken on ``blurred`` when ``grid`` was reshaped by roundness.
    With ``bands`` or ``frame``, a peak's height is first discounted by what its patch
    (above half its height) is: a band (``band_discount``) or a patch hugging the frame
    (``frame_share``).

    Examples
    --------
    >>> grid = np.zeros((40, 40), np.float32)
    >>> grid[10, 10], grid[30, 28], grid[12, 12] = 5.0, 3.0, 4.0
    >>> from cyborg.daemon.vision.params import PAPER
    >>> pts = find_points(InterestMap(grid, 1, (40, 40)), PAPER.replace(blur=5.0))
    >>> [(p.rank, p.x, p.y, p.score, p.radius) for p in pts]
    [(1, 10.0, 10.0, 5.0, 5.0), (2, 28.0, 30.0, 3.0, 5.0)]
    >>> ridge = np.zeros((20, 60), np.float32)
    >>> ridge[10, 5:55] = 1.0
    >>> ridge[10, [10, 45]] = 1.2                   # two bumps on one ridge: one target,
    >>> pts = find_points(InterestMap(ridge, 1, (20, 60)), PAPER.replace(blur=3.0, valley=0.5))
    >>> [(round(p.x), round(p.y), round(p.radius, 1)) for p in pts]  # aimed at its middle
    [(30, 10, 4.0)]
    """
    grid = imap.grid
    if params.top_n == 0 or grid.size == 0:
        return []
    f = imap.factor
    sep = params.separation(imap.shape) / f
    d = max(1, round(sep))
    local = cv2.dilate(grid, np.ones((2 * d + 1, 2 * d + 1), np.uint8))
    floor = float(grid.min())
    span = float(grid.max()) - floor
    if span <= 1e-6:
        return []
    peak = (grid >= local) & (grid > max(floor + 1e-3 * span, 0.0))
    rows, cols = np.nonzero(peak)
    chosen: list[tuple[int, int, float, float, float, float]] = []  # peak r, c; y, x; ...
    support = grid if imap.blurred is None else imap.blurred
    base = float(np.median(support))  # heights count from the map's typical level
    whole = support if imap.plain is None else imap.plain
    whole_base = float(np.median(whole))
    discount = max(params.bands, params.frame) > 0 and params.valley > 0
    width = _BAND_WIDTH * params.sigma(imap.shape) / f
    reach = _FRAME_REACH * params.sigma(imap.shape) / f
    # Highest first (ties by row, then column). A peak's discounts are worked out only when
    # it comes up, and the peak goes back at its discounted height: the discount never
    # raises a height, so what comes up already discounted is the highest left, and only
    # the few peaks above the last point chosen are ever measured.
    heap = [
        (-float(grid[r, c]), int(r), int(c), not discount) for r, c in zip(rows, cols, strict=True)
    ]
    heapq.heapify(heap)
    while heap and len(chosen) < params.top_n:
        key, r, c, final = heapq.heappop(heap)
        if not final:
            level = whole_base + _EXTENT * (float(whole[r, c]) - whole_base)
            patch = _patch(whole, r, c, level)
            shape = band_discount(patch, width) ** params.bands
            shape *= (1.0 - frame_share(patch, reach)) ** params.frame
            heapq.heappush(heap, (key * shape, r, c, True))
            continue
        value = -key
        if any((r - q[0]) ** 2 + (c - q[1]) ** 2 < sep * sep for q in chosen):
            continue
        (y, x), radius = _refine(grid, r, c), sep
        if params.valley > 0:
            level = whole_base + params.valley * (float(whole[r, c]) - whole_base)
            if any(_patch(whole, r, c, level)[q[0], q[1]] for q in chosen):
                continue
            height = float(support[r, c]) - base
            patch = _patch(support, r, c, base + _EXTENT * height)
            ring = _ring_below(support, r, c, patch, base=base, height=height)
            if ring is not None:  # aim at the ring's centre; it spans what it encloses
                y, x, area = ring
                radius = max(1.0, math.sqrt(area / math.pi))
            else:
                top = base + _TOP * height
                y, x = _centre(support, _patch(support, r, c, top), top, (y, x))
                y, x = _centre(support, patch, base + _EXTENT * height, (y, x))
                radius = max(1.0, math.sqrt(float(patch.sum()) / math.pi))
                y, x = _settle(support, base, y, x, radius)
            if any(math.hypot(y - q[2], x - q[3]) < max(radius, q[5]) for q in chosen):
                continue
        chosen.append((r, c, y, x, value, radius))
    return [
        InterestPoint(rank, x * f + (f - 1) / 2.0, y * f + (f - 1) / 2.0, value, radius * f)
        for rank, (_, _, y, x, value, radius) in enumerate(chosen, start=1)
    ]


def band_discount(patch: np.ndarray, width: float) -> float:
    """min(1, aspect / ``_BAND_ASPECT``) for a patch that is a band, else 1.

    A band is a patch whose spread across (the smaller standard deviation of its cells'
    positions) exceeds ``width``: wider than the blur makes a line, so a bed, the sky or a
    ledge's shadow, not a vein or a crack; its aspect is the ratio of the two deviations.
    Roundness (``isotropy``) judges the map's curvature at twice the blur, and along a
    band of uneven thickness or rarity it finds a string of round caps; the patch knows
    the whole band. A lens along the bedding (aspect 2.5-4) is not discounted.

    Examples
    --------
    >>> band = np.zeros((60, 200), bool)
    >>> band[20:32, :] = True
    >>> round(band_discount(band, 2.0), 2), band_discount(band, 5.0)
    (0.3, 1.0)
    >>> yy, xx = np.mgrid[:60, :200]
    >>> band_discount((yy - 30) ** 2 + (xx - 100) ** 2 < 400, 2.0)
    1.0
    """
    ys, xs = np.nonzero(patch)
    if len(ys) < 3:
        return 1.0
    across, along = np.sqrt(np.maximum(np.linalg.eigvalsh(np.cov(np.stack([ys, xs]))), 0.0))
    if across <= width:
        return 1.0
    return min(1.0, float(across / along) / _BAND_ASPECT)


def frame_share(patch: np.ndarray, reach: float) -> float:
    """The share of a patch's cells less than ``reach`` cells from the frame.

    The blur already counts the outside of the frame as typical rock, so a target cut by
    the frame scores for what is seen of it; but a bed running along the frame's edge, or
    the sliver of a rock the frame cuts, is still a whole patch of rare class, rare because
    the frame truncated its area. Discounting by the share that hugs the frame leaves a
    target inside the view alone and one crossing the edge mostly so.

    Examples
    --------
    >>> patch = np.zeros((50, 80), bool)
    >>> patch[20:30, 30:40] = True                  # well inside
    >>> frame_share(patch, 3.0)
    0.0
    >>> patch[:] = False
    >>> patch[0:4, 10:70] = True                    # a sliver along the top
    >>> frame_share(patch, 3.0)
    0.75
    """
    ys, xs = np.nonzero(patch)
    if len(ys) == 0:
        return 0.0
    rows, cols = patch.shape
    near = (np.minimum(ys, rows - 1 - ys) < reach) | (np.minimum(xs, cols - 1 - xs) < reach)
    return float(near.mean())


_FRAME_REACH = 1.5
"""Cells nearer the frame than 1.5 blur sigmas count as hugging it."""
_BAND_ASPECT = 0.2
"""Patches more elongated than 5 : 1 are discounted in proportion."""
_BAND_WIDTH = 1.5
"""A band is wider (standard deviation across) than 1.5 blur sigmas; a thinner one is a line
the blur made, a vein or a crack, and keeps its height. At one sigma, top-1 on veins rose
82.5 -> 87.5 % and on large targets to 84.2 %, but cracks (crackforest) fell 55 -> 50 %
and repeat@1 on large targets to 88.3 %."""


_EXTENT = 0.5
"""A point's radius is that of a disc of the area of its patch above half its height (the
full width at half maximum of a blob), whatever ``valley`` says about which peaks are one
target."""
_TOP = 0.8
"""Where the centre of a patch lies outside it (a crescent), the point starts from the
centre of mass of the patch's top (above 80 % of its height) instead: on a small spot that
is the spot. 0.8 rather than 0.9 was measured before the whole patch's centre came first
(veins repeat@1 89.6 -> 91.9 % over 480 scenes, the rest unchanged)."""


def _centre(
    support: np.ndarray, patch: np.ndarray, level: float, peak: tuple[float, float]
) -> tuple[float, float]:
    """The patch's centre of mass above ``level``: where the target is, steadier under
    sensor noise than its highest cell (a wide patch's peak wanders with the texture).
    Falls back to the peak when the centre lies outside the patch (a crescent)."""
    ys, xs = np.nonzero(patch)
    weight = support[ys, xs] - level + 1e-9
    y, x = float(ys @ weight / weight.sum()), float(xs @ weight / weight.sum())
    return (y, x) if patch[round(y), round(x)] else peak


_RING_LEVELS = (0.4, 0.3)
"""Heights (shares of a peak's) below its extent at which a ring is looked for again: a rim
much more interesting on one side closes into a ring only lower down."""
_SETTLE = 10
"""Most mean-shift steps :func:`_settle` takes (it stops when a step is under 0.05 cell)."""


def _ring_below(
    support: np.ndarray, r: int, c: int, patch: np.ndarray, *, base: float, height: float
) -> tuple[float, float, float] | None:
    """:func:`_ring` of the peak's patch at its extent, else at the lower ``_RING_LEVELS``."""
    ring = _ring(patch)
    for share in _RING_LEVELS:
        if ring is not None:
            break
        ring = _ring(_patch(support, r, c, base + share * height))
    return ring


def _settle(
    support: np.ndarray, base: float, y: float, x: float, radius: float
) -> tuple[float, float]:
    """Mean shift from (y, x) with a flat disc of the point's own radius over the heights
    above the typical level: the centre of the target's mass at its own scale. The top's
    centre leans to the target's most interesting side (a stain's rim seen from 60 m, the
    half of a patch a bed contact crosses), and the next station would be aimed there; the
    whole patch's centre is pulled away by a neighbour it merged with, the disc is not.
    Started from the whole patch's centre, not the top's: along a wide patch (a bed in a view
    with nothing in it, a long vein) the top wanders with the sensor noise and the disc
    settles wherever it was let go, the patch's centre stays put."""
    rows, cols = support.shape
    reach = math.ceil(radius) + 1
    for _ in range(_SETTLE):
        y0, y1 = max(0, round(y) - reach), min(rows, round(y) + reach + 1)
        x0, x1 = max(0, round(x) - reach), min(cols, round(x) + reach + 1)
        ys, xs = np.mgrid[y0:y1, x0:x1]
        inside = (ys - y) ** 2 + (xs - x) ** 2 <= radius * radius
        weight = np.clip(support[y0:y1, x0:x1] - base, 0.0, None) * inside
        total = float(weight.sum())
        if total <= 0.0:
            break
        ny, nx = float((ys * weight).sum()) / total, float((xs * weight).sum()) / total
        done = abs(ny - y) + abs(nx - x) < 0.05
        y, x = ny, nx
        if done:
            break
    return y, x


def _ring(patch: np.ndarray) -> tuple[float, float, float] | None:
    """The centre (y, x) and enclosed area of a ring-shaped patch, or None for any other
    shape.

    A stain seen from 60 m is interesting at its bright rim and its edges more than in its
    even interior, so its patch is a ring whose highest part is one side of the rim; the
    top's centre would aim the next station at the rim. A patch is a ring when the centre
    of the area it encloses (holes filled) lies in a hole: then that centre is the target's.
    """
    inside = np.pad(~patch, 1, constant_values=True).astype(np.uint8)
    cv2.floodFill(inside, None, (0, 0), 2)  # what is left at 1 is enclosed by the patch
    holes = inside[1:-1, 1:-1] == 1
    if not holes.any():
        return None
    ys, xs = np.nonzero(patch | holes)
    y, x = float(ys.mean()), float(xs.mean())
    return (y, x, float(len(ys))) if holes[round(y), round(x)] else None


def _patch(grid: np.ndarray, r: int, c: int, level: float) -> np.ndarray:
    """bool mask of the connected part of ``grid >= level`` (8-connected) holding (r, c)."""
    above = (grid >= level).astype(np.uint8)
    _, labels = cv2.connectedComponents(above, connectivity=8)
    return labels == labels[r, c]
