"""Interest points: the highest peaks of the interest map, one per target.

Points are peaks at least B apart. With ``valley`` > 0 two peaks are one target unless the
map dips below ``valley`` x the lower peak between them (a persistence test, free of any
size guess), so three points are three targets from a 5 px spot to a patch of 15 % of the
image; each point's radius is the size of its own patch. With ``bands`` and ``frame`` each
peak is judged by its whole patch, so beds, the skyline and slivers the frame cuts are
discounted. Peaks are found on the map's coarse grid and refined to sub-pixel positions.
A point whose score cannot be told from the map's background is kept, in its place, and
marked "no further target" (``mark_background``).
"""

from __future__ import annotations

import dataclasses
import heapq
import math

import cv2
import numpy as np

from .interest import InterestMap, InterestPoint
from .kernels import kernel
from .order import median
from .params import VisionParams

__all__ = [
    "SHARE",
    "SPREADS",
    "background",
    "band_discount",
    "find_points",
    "frame_share",
    "mark_background",
]

SPREADS = 0.25
"""A target stands more than a quarter of a robust standard deviation of the interest map
above its median (``mark_background``). ``bench.targets``: the lowest point that hit a
target stood 0.38 deviations up (default) and 0.75 (paper); at 0.5 one target is lost."""
SHARE = 0.025
"""... and at least 2.5 % of the best point's height over the median. ``bench.targets``: the
lowest share of a point that hit a target was 3.1 %; the demo's 60 m noise 0.4-1.4 %."""


def _refine(grid: np.ndarray, r: int, c: int) -> tuple[float, float]:
    """Sub-cell peak position by a parabola through the 3 samples on each axis."""

    def offset(a: float, b: float, d: float) -> float:
        den = a - 2.0 * b + d
        return 0.0 if den >= 0 else float(np.clip(0.5 * (a - d) / den, -0.5, 0.5))

    rows, cols = grid.shape
    dy = offset(grid[r - 1, c], grid[r, c], grid[r + 1, c]) if 0 < r < rows - 1 else 0.0
    dx = offset(grid[r, c - 1], grid[r, c], grid[r, c + 1]) if 0 < c < cols - 1 else 0.0
    return r + dy, c + dx


_FLAT = 1e-4
"""A map whose highest cell stands less than this above its lowest is flat: float rounding
in the filters (a black row gave line rarity of 1e-6 once OpenCV ran its own code instead of
IPP's), not contrast; a real image's maps span whole units."""


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
    if span <= _FLAT:
        return []
    peak = (grid >= local) & (grid > max(floor + 1e-3 * span, 0.0))
    rows, cols = np.nonzero(peak)
    chosen: list[tuple[int, int, float, float, float, float]] = []  # peak r, c; y, x; ...
    support = grid if imap.blurred is None else imap.blurred
    base = float(median(support))  # heights count from the map's typical level
    whole = support if imap.plain is None else imap.plain
    whole_base = float(median(whole))
    discount = max(params.bands, params.frame) > 0 and params.valley > 0
    width = _BAND_WIDTH * params.sigma(imap.shape) / f
    reach = _FRAME_REACH * params.sigma(imap.shape) / f
    # Highest first (ties by row, then column). A peak's discounts are worked out only when
    # it comes up, and the peak goes back at its discounted height: the discount never
    # raises a height, so what comes up already discounted is the highest left, and only
    # the few peaks above the last point chosen are ever measured.
    queue = _Queue(grid[rows, cols], rows, cols, final=not discount)
    while len(chosen) < params.top_n and (item := queue.pop()) is not None:
        key, r, c, final = item
        if not final:
            level = whole_base + _EXTENT * (float(whole[r, c]) - whole_base)
            patch = _patch(whole, r, c, level)
            shape = band_discount(patch, width) ** params.bands
            shape *= (1.0 - frame_share(patch, reach)) ** params.frame
            queue.push(key * shape, r, c)
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


class _Queue:
    """Peaks highest first, ties by row then column, as a heap of (-height, row, column,
    final) would give them: one sort of every peak, and a heap for the few that go back at
    a discounted height. A heap of every peak held 1.5 M Python tuples on a flat 8000x4000
    panorama."""

    def __init__(self, heights: np.ndarray, rows: np.ndarray, cols: np.ndarray, *, final: bool):
        self._order = np.argsort(-heights, kind="stable")  # np.nonzero is row-major
        self._heights, self._rows, self._cols, self._final = heights, rows, cols, final
        self._next = 0
        self._back: list[tuple[float, int, int]] = []

    def push(self, key: float, r: int, c: int) -> None:
        """Put a peak back, final, at ``key`` (minus its discounted height)."""
        heapq.heappush(self._back, (key, r, c))

    def pop(self) -> tuple[float, int, int, bool] | None:
        """The highest peak left as (-height, row, column, final); None when none is."""
        if self._next < len(self._order):
            k = self._order[self._next]
            head = (-float(self._heights[k]), int(self._rows[k]), int(self._cols[k]))
            if not self._back or head < self._back[0]:  # a peak is in one of the two only
                self._next += 1
                return (*head, self._final)
        return (*heapq.heappop(self._back), True) if self._back else None


def mark_background(
    imap: InterestMap,
    points: list[InterestPoint],
    *,
    spreads: float = SPREADS,
    share: float = SHARE,
) -> list[InterestPoint]:
    """The points, in their order, each marked ``target=False`` ("no further target") when
    its score cannot be told from the view's background.

    A point is background when its height over the map's median is at most ``spreads``
    robust standard deviations of the map (:func:`background`), or under ``share`` of the
    best point's height: where it stands the map is within its own bulk, or a ripple of
    what the best point shows. Both are read off the map the scores come from, so the rule
    is the same on every profile's scale (the seed's raw uncommon sums, the fused map's
    units) and under a prior. A score at or under the median (a sliver the frame discounts
    to 0) is always background. The defaults are measured (``bench.targets``, whose
    docstring gives the figures): no point that hit a planted or labelled target alone was
    marked.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> grid = rng.normal(0.0, 0.1, (40, 40)).astype(np.float32)
    >>> grid[10, 10] = 4.0                          # one target in a noisy view
    >>> imap = InterestMap(grid, 1, (40, 40))
    >>> pts = [InterestPoint(1, 10.0, 10.0, 4.0), InterestPoint(2, 30.0, 30.0, 0.05),
    ...        InterestPoint(3, 5.0, 30.0, 0.3)]
    >>> [(p.rank, p.target) for p in mark_background(imap, pts)]
    [(1, True), (2, False), (3, True)]
    """
    if not points:
        return []
    typical, spread = background(imap.grid)
    best = max(p.score for p in points) - typical
    floor = max(spreads * spread, share * best, 0.0)
    return [dataclasses.replace(p, target=p.score - typical > floor) for p in points]


def background(grid: np.ndarray) -> tuple[float, float]:
    """The view's background on an interest map: its median and its robust standard
    deviation (1.4826 x the median absolute deviation, the standard deviation of normal
    noise), unmoved by the few cells a target covers.

    >>> typical, spread = background(np.array([[0.0, 1.0, 2.0], [3.0, 4.0, 90.0]]))
    >>> typical, round(spread, 4)                   # the 90 moves neither
    (2.5, 2.2239)
    """
    typical = float(median(grid))
    return typical, _MAD_SIGMA * float(median(np.abs(grid - typical)))


_MAD_SIGMA = 1.4826
"""The median absolute deviation of normal noise times this is its standard deviation."""


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
    n, syy, sxx, sxy = _spread(patch)
    if n < 3:
        return 1.0
    half, gap = (syy + sxx) / 2.0, math.hypot((syy - sxx) / 2.0, sxy)  # the eigenvalues
    across, along = math.sqrt(max(half - gap, 0.0)), math.sqrt(max(half + gap, 0.0))
    if across <= width:
        return 1.0
    return min(1.0, across / along / _BAND_ASPECT)


@kernel
def _spread(patch: np.ndarray) -> tuple[int, float, float, float]:
    """The number of a mask's cells and their positions' covariance (``np.cov``'s: rows,
    columns, and between; n - 1 in the denominator), in two passes over the mask: the
    positions were gathered, stacked and multiplied by numpy calls costing more than the
    arithmetic."""
    rows, cols = patch.shape
    n, sy, sx = 0, 0, 0
    for y in range(rows):
        for x in range(cols):
            if patch[y, x]:
                n, sy, sx = n + 1, sy + y, sx + x
    if n < 2:
        return n, 0.0, 0.0, 0.0
    my, mx = sy / n, sx / n
    syy = sxx = sxy = 0.0
    for y in range(rows):
        for x in range(cols):
            if patch[y, x]:
                dy, dx = y - my, x - mx
                syy, sxx, sxy = syy + dy * dy, sxx + dx * dx, sxy + dy * dx
    return n, syy / (n - 1), sxx / (n - 1), sxy / (n - 1)


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
    cells, near = _near_frame(patch, reach)
    return near / cells if cells else 0.0


@kernel
def _near_frame(patch: np.ndarray, reach: float) -> tuple[int, int]:
    """How many cells the mask holds, and how many of them lie less than ``reach`` cells
    from the frame: one pass, where gathering the positions cost more than counting."""
    rows, cols = patch.shape
    cells = near = 0
    for y in range(rows):
        for x in range(cols):
            if patch[y, x]:
                cells += 1
                if min(y, rows - 1 - y) < reach or min(x, cols - 1 - x) < reach:
                    near += 1
    return cells, near


_FRAME_REACH = 1.5
"""Cells nearer the frame than 1.5 blur sigmas count as hugging it."""
_BAND_ASPECT = 0.2
"""Patches more elongated than 5 : 1 are discounted in proportion."""
_BAND_WIDTH = 1.5
"""A band is wider (standard deviation across) than 1.5 blur sigmas; a thinner one is a line
the blur made, a vein or a crack, and keeps its height."""


_EXTENT = 0.5
"""A point's radius is that of a disc of the area of its patch above half its height (the
full width at half maximum of a blob), whatever ``valley`` says about which peaks are one
target."""
_TOP = 0.8
"""Where the centre of a patch lies outside it (a crescent), the point starts from the
centre of mass of the patch's top (above 80 % of its height) instead: on a small spot that
is the spot."""


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
    return _mean_shift(support, np.float32(base), y, x, radius)


@kernel
def _mean_shift(
    support: np.ndarray, base: np.float32, y: float, x: float, radius: float
) -> tuple[float, float]:
    """:func:`_settle`'s steps in one compiled loop: each window was a dozen numpy calls."""
    rows, cols = support.shape
    reach = math.ceil(radius) + 1
    zero = np.float32(0.0)
    for _ in range(_SETTLE):
        y0, y1 = max(0, round(y) - reach), min(rows, round(y) + reach + 1)
        x0, x1 = max(0, round(x) - reach), min(cols, round(x) + reach + 1)
        total, wy, wx = zero, 0.0, 0.0
        for r in range(y0, y1):
            for c in range(x0, x1):
                if (r - y) ** 2 + (c - x) ** 2 <= radius * radius:
                    weight = max(support[r, c] - base, zero)
                    total += weight
                    wy, wx = wy + r * weight, wx + c * weight
        if total <= 0.0:
            break
        ny, nx = wy / total, wx / total
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
    """bool mask of the connected part of ``grid >= level`` (8-connected) holding (r, c);
    all of ``grid < level`` when (r, c) is below it (the background, as a labelling has it).
    A flood from (r, c) visits that part alone; labelling the whole map cost more."""
    above = (grid >= level).astype(np.uint8)
    if not above[r, c]:
        return above == 0
    cv2.floodFill(above, None, (int(c), int(r)), 2, flags=8)
    return above == 2
