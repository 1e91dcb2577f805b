"""Aims of study: the points of the kind a scientist asks for first, excluded kinds last.

An aim (``protocol.aims``, ``VisionParams.aim``) names one kind sought first (``dark``: wet
stains, dark lenses; ``bright``: veins, evaporites; ``colour``: lichen, oxides) and kinds set
aside (``no-vegetation``, ``no-sky``). The science finds what is uncommon as before; an aim
reweights that evidence by what each pixel looks like, from the same planes the explanation
reads (a point's tone against the image, its colour, its shade likelihood, its thin lines):

* dark / bright patches (a stain, a lens, a crust): darker (brighter) than half to three
  quarters of the image and 5-15 % darker (brighter) than the rock a few per cent of the
  diagonal away on all sides but one (at a bed's edge, along a bed or under the skyline,
  two sides or more are the pixel's own surface: a step is no patch; past the frame or in
  the sky the rock is unseen and counts as its own surface too), with a body (the grain is
  none), not on a layer across the view (bright: not on a bed of that tone across it), not
  a sliver lying along the bedding (a piece of a thin bed, a ledge's shadow), neither
  strongly coloured, green nor sky, and (dark) not probably in shade (bright: a shadow or
  a stain is no rock to be brighter than);
* bright veins: the explanation's thin bright lines (``lines``), a connected run a few per
  cent of the diagonal long, not a shadow's lit rim, and weighing half when it runs along a
  contact (a darker bed on one side all along it) rather than across the rock; a dark patch
  is not where one crosses;
* colour: a chroma (max - min of B, G, R) three times the image's typical one and at least
  30 of 255, not green;
* vegetation: green (hue 70-170 degrees) with an excess of green 2G - R - B of 20-50;
* sky: smooth, at least as blue as red, brighter than the image's median, in an unbroken run
  down from the top of the view.

Points are then found again (``peaks.find_points`` itself) on the interest of the evidence
weighted per pixel before the blur (``aimed_map``): once on the sought kind's alone (a stain
that the valley rule merged into a plant's patch stands on its own once the plant weighs
nothing), once with the excluded kinds taken out. Every point is scored on the science's own
map and given the kind its core looks like (``point_kinds``). The report lists targets
before "no further target": the sought kind's first (dark and bright by how much of that
kind lies around each: a stain's body, a vein's run, before a crumb; colour by its height on
its kind's own map; none when nothing in view is of that kind), then the other kinds, then
the excluded ones (by score). The science's own best point is always reported, so a
striking target of another kind is never hidden, only ranked after. ``any`` leaves the points
exactly as they were (``bench.aims`` measures all this on mixed scenes).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import cv2
import numpy as np

from cyborg.protocol.aims import Aim, parse_aim

from .cooccurrence import Segmentation
from .hsi import HSIPlanes
from .interest import InterestMap, InterestPoint, interest_map
from .lines import line_shade
from .params import VisionParams
from .peaks import find_points, mark_background

__all__ = ["KIND_NAMES", "aim_entry", "aim_points", "aimed_map", "kind_maps", "point_kinds"]

KIND_NAMES = ("sky", "vegetation", "colour", "dark", "bright")
"""The kinds a point can be, in the order ties go; a point of none is ``other``."""
_EXCLUDES = {"no-vegetation": "vegetation", "no-sky": "sky"}
"""The kind each exclusion sets aside."""


def _ramp(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """0 below ``lo``, 1 above ``hi``, linear between (float32)."""
    return np.clip((x - np.float32(lo)) / np.float32(hi - lo), 0.0, 1.0).astype(np.float32)


def kind_maps(
    bgr: np.ndarray,
    hsi: HSIPlanes,
    shade: np.ndarray | None = None,
    bars: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """How much each pixel looks like each kind of :data:`KIND_NAMES`, 0..1.

    Parameters
    ----------
    bgr : (M, N, 3) uint8 ndarray
        The analysed image.
    hsi : HSIPlanes
        Its H, S, I planes (``hsi.rgb_to_hsi``), as the explanation reads them.
    shade : (M, N) float32 ndarray, optional
        Shadow likelihood (``shadow.shadow_likelihood``): a dark patch in shade is not a dark
        target.
    bars : (M, N) float32 ndarray, optional
        Signed line rarity (``lines.line_rarity``): a connected thin bright line is a vein,
        bright however faint against the image, and no dark target where it crosses one.

    Returns
    -------
    dict of (M, N) float32 ndarrays, one per kind

    Examples
    --------
    >>> from cyborg.daemon.vision.hsi import rgb_to_hsi
    >>> img = np.full((60, 80, 3), (150, 165, 180), np.uint8)   # pale buff rock
    >>> img[:12] = (230, 200, 170)                                # a blue sky
    >>> img[30:36, 10:16] = (50, 150, 70)                         # a plant
    >>> img[30:36, 40:46] = (95, 100, 105)                        # a wet stain
    >>> img[30:36, 60:66] = (30, 150, 230)                        # an orange lichen
    >>> maps = kind_maps(img, rgb_to_hsi(img))
    >>> [[k for k in KIND_NAMES if maps[k][y, x] > 0.5] for y, x in
    ...  ((5, 40), (33, 13), (33, 43), (33, 63), (50, 40))]
    [['sky'], ['vegetation'], ['dark'], ['colour'], []]
    """
    if bgr.ndim != 3 or bgr.shape[2] != 3 or bgr.dtype != np.uint8:
        raise ValueError(f"expected (M, N, 3) uint8, got {bgr.shape} {bgr.dtype}")
    rows, cols = hsi.i.shape
    b, g, r = cv2.split(cv2.GaussianBlur(bgr, (0, 0), 1.0).astype(np.float32))
    chroma = cv2.max(cv2.max(b, g), r) - cv2.min(cv2.min(b, g), r)
    typical = float(np.median(chroma[:: max(1, rows // 256), :: max(1, cols // 256)]))
    hue = hsi.h.astype(np.float32) * np.float32(360.0 / 256.0)
    green_hue = ((hue >= _GREEN[0]) & (hue <= _GREEN[1])).astype(np.float32)
    vegetation = green_hue * _ramp(2 * g - r - b, *_EXCESS_GREEN) * _ramp(chroma, *_CHROMA)
    c0 = max(_CHROMA[1], _CHROMA_TIMES * typical)
    colour = _ramp(chroma, c0, 1.5 * c0) * (1 - vegetation)
    sky = _sky(hsi.i, b, r)
    # Tone is read on the intensity smoothed over the rock's grain: a bed is one tone, and a
    # grain darker than its neighbours is no dark feature.
    level = cv2.GaussianBlur(hsi.i, (0, 0), _GRAIN)
    counts = np.bincount(level.ravel(), minlength=256).astype(np.float64)
    below = np.concatenate([[0.0], np.cumsum(counts)]) / level.size
    darker = (1.0 - below[level.astype(np.int64) + 1]).astype(np.float32)  # share brighter
    brighter = below[level.astype(np.int64)].astype(np.float32)  # share darker
    # The surroundings on every side: a stain or a crust differs from all of them, a bed's
    # edge from one side only; the sky is no rock's surroundings (the rock's median there).
    ground = level
    if sky.any():
        ground = np.where(sky >= 0.5, np.uint8(np.median(level[sky < 0.5])), level)
    reach = _SURROUND * math.hypot(rows, cols)
    unseen = sky >= 0.5
    tone, lightest, darkest = _ring(ground, reach, unseen)
    deeper = 1.0 - tone / darkest  # darker than all around it
    # A plant's or a lichen's rim (its colour blurred into the rock's) is not a dark or bright
    # feature of its own: the tone kinds keep clear of the coloured ones by a few pixels.
    coloured = cv2.dilate(cv2.max(cv2.max(colour, vegetation), sky), _RIM)
    plain = 1 - coloured
    dark = _ramp(darker, *_TONE) * _ramp(deeper, *_LOCAL) * plain
    if shade is not None:
        dark *= 1.0 - shade
    dark = _no_layers(_patches(dark))
    # A shadow or a stain is no rock for a crust to be brighter than: the bed's piece between
    # a stain and the frame is no crust.
    hidden = cv2.dilate((dark >= _RIM_LEVEL).astype(np.uint8), _RIM) > 0
    if shade is not None:
        hidden |= shade >= 0.5
    if hidden.any():
        lightest = _ring(np.where(hidden, np.uint8(255), ground), reach, unseen)[1]
    lighter = tone / lightest - 1.0  # brighter than all around it, by so much
    # A crust is brighter than the rock around it on a bed that is not the view's brightest
    # across it: on a white bed that runs across the view, any brighter patch is the bed's.
    light = _ramp(brighter, *_TONE)
    bright = _no_layers(_patches(light * _ramp(lighter, *_LOCAL) * plain), light)
    vein = np.zeros_like(bright)
    if bars is not None:
        vein = _veins(bars, hsi.i) * plain
        if shade is not None:  # a shadow's lit rim is no vein
            vein *= 1.0 - line_shade(bars * bars, shade)
    # A piece of a thin bed or a ledge's shadow lies along the bedding; a stain does not.
    bedding = _bedding(hsi.i, cv2.max(cv2.max(dark, bright), vein) >= _RIM_LEVEL)
    dark = _across(dark, bedding) * (1.0 - cv2.dilate(vein, _SPECK))
    bright = cv2.max(_across(bright, bedding), vein)
    return {"sky": sky, "vegetation": vegetation, "colour": colour, "dark": dark, "bright": bright}


_GREEN = (70.0, 170.0)
"""Hue (degrees, geometric HSI) of green plants: yellow-green to cyan-green."""
_EXCESS_GREEN = (20.0, 50.0)
"""2G - R - B (of 255) from which a green pixel is a plant: grey-green clay has under 15."""
_CHROMA = (20.0, 30.0)
"""Chroma (max - min of B, G, R) from which a pixel has a colour at all."""
_CHROMA_TIMES = 3.0
"""A strongly coloured pixel has this many times the image's typical chroma (and >= 30)."""
_TONE = (0.5, 0.75)
"""Dark (bright): darker (brighter) than 50 % .. 75 % of the image ..."""
_LOCAL = (0.05, 0.15)
"""... and 5 % .. 15 % darker (brighter) than its surroundings: a dark bed is no dark
feature, and a stain on a pale bed among darker ones is one."""
_GRAIN = 1.0
"""Gaussian sigma (analysed pixels) of the smoothing tone is read after."""
_SURROUND = 0.06
"""How far a pixel's surroundings lie, as a share of the image diagonal (22 px at 216x288):
past the rim of a stain of 2 % of the view seen from its core."""
_RIM = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (7, 7))
"""How far the tone kinds keep clear of coloured pixels: a blurred rim is 2-3 px wide."""
_BODY = 0.014
"""Width of the opening that keeps a layer's body, as a share of the image diagonal: 5 px at
216x288, where veins are 1.5-3 px wide and beds 10 px or more."""
_SPECK = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3))
"""A gap smaller than this (a noisy pixel) does not end a sky's run nor split a layer."""
_SKY_STD = (3.0, 6.0)
"""Local standard deviation of I (of 255) below which a surface is as smooth as a sky."""


def _ring(
    level: np.ndarray, reach: float, unseen: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The level smoothed over a sixth of ``reach`` (float32, + 1), and the second lightest
    and the second darkest of it ``reach`` px away in eight directions: a patch is darker
    (brighter) than all but one of them (a stain may touch a shadow on one side); at a bed's
    edge, along a bed or under the skyline two or more of them are the pixel's own surface,
    seen through the same smoothing. Straight up, down or across, past the frame or in the
    sky (``unseen``), the rock is not seen: it counts as the pixel's own surface, so a bed's
    piece cut by the frame or the skyline, whose one side is its own bed, is not a patch (a
    diagonal there reads the frame's edge, or ``level`` in the sky)."""
    rows, cols = level.shape
    smooth = cv2.GaussianBlur(level.astype(np.float32), (0, 0), reach / 6) + np.float32(1.0)
    e = math.ceil(reach)
    padded = cv2.copyMakeBorder(smooth, e, e, e, e, cv2.BORDER_REPLICATE)
    seen = cv2.copyMakeBorder((~unseen).astype(np.uint8), e, e, e, e, cv2.BORDER_CONSTANT, 0)
    around = np.empty((8, rows, cols), np.float32)
    for k in range(8):
        dy, dx = round(reach * math.sin(k * math.pi / 4)), round(reach * math.cos(k * math.pi / 4))
        around[k] = padded[e + dy : e + dy + rows, e + dx : e + dx + cols]
        if k % 2 == 0:  # straight: what is not seen there is the pixel's own surface
            there = seen[e + dy : e + dy + rows, e + dx : e + dx + cols] > 0
            around[k] = np.where(there, around[k], smooth)
    around.sort(axis=0)
    return smooth, around[-2], around[1]


def _sky(i: np.ndarray, b: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The sky's likelihood: smooth, as blue as red or bluer, brighter than the image's
    median, down from the top of the view in an unbroken run along each column, under a
    skyline that runs on across the view (a run's length, median-filtered along the row)."""
    rows, cols = i.shape
    inten = i.astype(np.float32)
    mean = cv2.blur(inten, (5, 5))
    std = cv2.sqrt(cv2.max(cv2.blur(inten * inten, (5, 5)) - mean * mean, 0.0))
    like = (1 - _ramp(std, *_SKY_STD)) * _ramp(b - r, -8.0, 0.0)
    typical = float(np.median(i))
    like *= _ramp(mean, typical, typical + 10.0)
    broken = cv2.morphologyEx((like < 0.5).astype(np.uint8), cv2.MORPH_OPEN, _SPECK)
    broken[-1] = 1  # every run ends
    run = np.argmax(broken, axis=0).astype(np.float32)  # rows of sky from the top, per column
    width = max(3, (cols // 8) | 1)
    skyline = np.minimum(run, _median_along(run, width))
    if float(np.mean(skyline >= 3)) < 0.5:  # no strip across the view: no sky
        return np.zeros_like(like)
    below = np.arange(rows, dtype=np.float32)[:, None] >= skyline[None, :]
    return np.where(below, 0.0, like).astype(np.float32)


def _median_along(values: np.ndarray, width: int) -> np.ndarray:
    """A running median of ``width`` (odd) over a 1-D array, edges repeated."""
    half = width // 2
    padded = np.pad(values, half, mode="edge")
    windows = np.lib.stride_tricks.sliding_window_view(padded, width)
    return np.median(windows, axis=1).astype(np.float32)


def _veins(bars: np.ndarray, intensity: np.ndarray) -> np.ndarray:
    """Pixels of thin bright lines (float32, 1 on a vein): connected runs of bar contrast above
    ``_VEIN_Z[0]`` robust standard deviations that reach ``_VEIN_Z[1]`` on a few pixels and
    run ``_VEIN_LENGTH`` of the diagonal; a grain or the grain's noise is no run. On a grainy
    bed both levels rise to ``_VEIN_GRAIN`` (twice that) times the mean bar contrast around
    the pixel: the bed's own noise is no vein. A vein crosses the rock it cuts: a run along a
    contact (a bed's lit rim, a thin bed between two others, the skyline) has a darker rock
    on one side all along it, and weighs half as much when most of its contrast is that
    step (``_CONTACT``, on ``intensity``). A vein runs on: a run weighs less the shorter it spans
    than the longest vein in view (``_SPAN``), as the grain's curls and a bed's crumbs do
    beside a vein."""
    rows, cols = bars.shape
    size = 2 * round(_SURROUND * math.hypot(rows, cols)) + 1
    grain = cv2.blur(np.abs(bars), (size, size)) * np.float32(_VEIN_GRAIN)
    weak = (bars > cv2.max(grain, _VEIN_Z[0])).astype(np.uint8)
    count, labels, stats, _ = cv2.connectedComponentsWithStats(weak, connectivity=8)
    strong = np.bincount(labels[bars > cv2.max(2 * grain, _VEIN_Z[1])], minlength=count)
    extent = np.maximum(stats[:, cv2.CC_STAT_WIDTH], stats[:, cv2.CC_STAT_HEIGHT])
    keep = (strong >= _VEIN_SEEDS) & (extent >= _VEIN_LENGTH * math.hypot(rows, cols))
    keep[0] = False
    if not keep.any():
        return np.zeros(bars.shape, np.float32)
    major, _, axis = _axes(labels, count)
    along = _ramp(_contacts(intensity, labels, keep, axis), *_CONTACT)
    crossing = np.where(keep, 1.0 - _CONTACT_WEIGHT * along, 0.0)
    span = 4 * np.sqrt(major) * crossing  # four standard deviations, along a contact less
    weight = _ramp(span / span.max(), *_SPAN) * crossing
    return weight.astype(np.float32)[labels]


def _axes(labels: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each labelled region's spread along its main axis and across it (variances, px²) and
    the main axis' angle from the x axis (radians), float64 arrays of ``count``: a vein's
    span, a curled run of grain short however many pixels it holds, a bed's sliver long."""
    ys, xs = np.nonzero(labels)
    lab = labels[ys, xs]
    n = np.maximum(np.bincount(lab, minlength=count), 1)

    def mean(v: np.ndarray) -> np.ndarray:
        return np.bincount(lab, weights=v, minlength=count) / n

    x, y = xs.astype(np.float64), ys.astype(np.float64)
    mx, my = mean(x), mean(y)
    sxx, syy, sxy = mean(x * x) - mx * mx, mean(y * y) - my * my, mean(x * y) - mx * my
    half = np.sqrt(((sxx - syy) / 2) ** 2 + sxy * sxy)
    major = np.maximum((sxx + syy) / 2 + half, 0.0)
    minor = np.maximum((sxx + syy) / 2 - half, 0.0)
    return major, minor, 0.5 * np.arctan2(2 * sxy, sxx - syy)


def _contacts(
    intensity: np.ndarray, labels: np.ndarray, keep: np.ndarray, axis: np.ndarray
) -> np.ndarray:
    """Per kept run, the share of its contrast that is a step across it (float64, 0 on a
    vein inside one bed, towards 1 on a line along a contact): the rock ``_SIDE`` px to
    either side of each pixel (across the ridge there, the Hessian's steepest downward
    curvature, turned to the run's own side), the median difference of the two sides over
    the run against that of the run above its brighter side."""
    rows, cols = intensity.shape
    g = cv2.GaussianBlur(intensity.astype(np.float32), (0, 0), _SIDE_BLUR)
    ixx = cv2.Sobel(g, cv2.CV_32F, 2, 0, ksize=3)
    iyy = cv2.Sobel(g, cv2.CV_32F, 0, 2, ksize=3)
    ixy = cv2.Sobel(g, cv2.CV_32F, 1, 1, ksize=3)
    across = 0.5 * cv2.phase(ixx - iyy, 2 * ixy) + np.float32(math.pi / 2)
    nx, ny = np.cos(across), np.sin(across)
    yy, xx = np.mgrid[0:rows, 0:cols].astype(np.float32)
    left = cv2.remap(
        g, xx + _SIDE * nx, yy + _SIDE * ny, cv2.INTER_LINEAR, None, cv2.BORDER_REPLICATE
    )
    right = cv2.remap(
        g, xx - _SIDE * nx, yy - _SIDE * ny, cv2.INTER_LINEAR, None, cv2.BORDER_REPLICATE
    )
    bar = cv2.max(g - cv2.max(left, right), 0.0)
    share = np.zeros(len(keep))
    for k in np.flatnonzero(keep):
        on = labels == k
        side = np.sign(nx[on] * -math.sin(axis[k]) + ny[on] * math.cos(axis[k]) + 1e-9)
        step = abs(float(np.median((left[on] - right[on]) * side)))
        share[k] = step / (step + float(np.median(bar[on])) + 1e-3)
    return share


_VEIN_Z = (2.5, 5.0)
"""A vein's pixels are brighter than both sides by this many robust standard deviations of
the image's own bar contrast (``lines``), and it is this bright somewhere."""
_VEIN_GRAIN = 3.0
"""A vein stands this many times above the mean bar contrast of the rock around it."""
_VEIN_SEEDS = 3
"""Pixels at the higher level a vein has at least."""
_VEIN_LENGTH = 0.033
"""A vein's length (its bounding box's longer side) at least, as a share of the diagonal:
12 px at 216x288, where veins run 40-120 px and grains are one or two."""
_SPAN = (0.4, 0.7)
"""A run weighs less below this share of the longest run's span in view (0 at the lower):
the grain of a bed curls into short runs, a vein runs on."""
_CONTACT = (0.3, 0.5)
"""A run lies along a contact from this share of its contrast being a step across it (wholly
at the upper): a vein inside one bed has under 0.25 (its grain), a line along a contact more."""
_CONTACT_WEIGHT = 0.5
"""How much less a run along a contact weighs: still bright (a vein may follow a bedding
plane), but after a vein that crosses the beds, and half as long beside it."""
_SIDE = 4.0
"""How far (px) to either side of a run the rock it crosses is read: past a 3 px vein's rim."""
_SIDE_BLUR = 1.5
"""Gaussian sigma (px) the sides and the ridge's direction are read after."""


def _patches(like: np.ndarray) -> np.ndarray:
    """``like`` on its patches only: a region where it is at least ``_RIM_LEVEL`` that holds
    a body (where it is at least 0.5 and an opening by ``_BODY`` of the diagonal leaves
    something) is a stain, a lens or a crust; one without is the rock's grain, which darkens
    or brightens a pixel here and there, and goes to 0."""
    rows, cols = like.shape
    size = max(3, 2 * round(_BODY * math.hypot(rows, cols) / 2) + 1)
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    body = cv2.morphologyEx((like >= 0.5).astype(np.uint8), cv2.MORPH_OPEN, disc)
    count, labels = cv2.connectedComponents((like >= _RIM_LEVEL).astype(np.uint8), None, 8)
    has = np.bincount(labels[body > 0], minlength=count) > 0
    has[0] = False
    return np.where(has[labels], like, 0.0).astype(np.float32)


_RIM_LEVEL = 0.1
"""Likelihood down to which a patch's blurred rim belongs to it."""


def _no_layers(like: np.ndarray, region: np.ndarray | None = None) -> np.ndarray:
    """``like`` without its layers: the body (what an opening by ``_BODY`` of the diagonal
    leaves: no vein, no crack) of a region spanning half the view's width or height is a bed
    or a band of the view, not a feature on the outcrop. A region is where ``like`` blurred
    by ``_JOIN`` of the diagonal is at least ``_JOINED``: a bed's rim or its grain flags it
    in pieces, which join into one band. The layers are found on ``region`` if given (the
    tone alone: a bed of that tone)."""
    rows, cols = like.shape
    diagonal = math.hypot(rows, cols)
    size = max(3, 2 * round(_BODY * diagonal / 2) + 1)
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))
    joined = cv2.GaussianBlur(like if region is None else region, (0, 0), _JOIN * diagonal)
    joined = joined >= _JOINED
    body = cv2.morphologyEx(joined.astype(np.uint8), cv2.MORPH_OPEN, disc)
    _, labels, stats, _ = cv2.connectedComponentsWithStats(body, connectivity=8)
    wide = (stats[:, cv2.CC_STAT_WIDTH] >= cols / 2) | (stats[:, cv2.CC_STAT_HEIGHT] >= rows / 2)
    wide[0] = False
    if not wide.any():
        return like
    layer = cv2.dilate(wide[labels].astype(np.uint8), _SPECK)
    return np.where(layer > 0, 0.0, like).astype(np.float32)


def _bedding(intensity: np.ndarray, aside: np.ndarray) -> tuple[np.ndarray, ...]:
    """The bedding's structure tensor (Jxx, Jyy, Jxy of the intensity's gradient, float32),
    averaged over ``_SURROUND`` of the diagonal without the pixels ``aside`` (the tone
    kinds' patches, widened by their rim): a patch's own outline says nothing of the beds
    it lies on, the contacts around it do."""
    rows, cols = intensity.shape
    g = cv2.GaussianBlur(intensity.astype(np.float32), (0, 0), _BED_BLUR)
    gx = cv2.Sobel(g, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(g, cv2.CV_32F, 0, 1, ksize=3)
    weight = 1.0 - cv2.dilate(aside.astype(np.uint8), _RIM).astype(np.float32)
    sigma = _SURROUND * math.hypot(rows, cols)

    def average(m: np.ndarray) -> np.ndarray:
        return cv2.GaussianBlur(m * weight, (0, 0), sigma)

    norm = cv2.max(average(np.ones_like(weight)), 1e-3)
    return tuple(average(m) / norm for m in (gx * gx, gy * gy, gx * gy))


def _across(like: np.ndarray, bedding: tuple[np.ndarray, ...]) -> np.ndarray:
    """``like`` without its patches that lie along the bedding: a region (where ``like`` is
    at least ``_RIM_LEVEL``) ``_ELONGATED`` times longer than wide whose long axis is within
    ``_ALONG`` of the beds' direction around it (the bedding's structure tensor, where it is
    ``_COHERENT``) is a piece of a thin bed or a ledge's shadow; a stain, a crust or a lens
    seen across the beds is not, and keeps its likelihood."""
    count, labels = cv2.connectedComponents((like >= _RIM_LEVEL).astype(np.uint8), None, 8)
    if count < 2:
        return like
    major, minor, axis = _axes(labels, count)
    n = np.maximum(np.bincount(labels.ravel(), minlength=count), 1)
    jxx, jyy, jxy = (np.bincount(labels.ravel(), m.ravel(), count) / n for m in bedding)
    coherent = np.hypot(jxx - jyy, 2 * jxy) / np.maximum(jxx + jyy, 1e-6)
    beds = 0.5 * np.arctan2(2 * jxy, jxx - jyy) + math.pi / 2  # across the steepest gradient
    aligned = np.abs(np.cos(axis - beds))
    along = (
        _ramp(np.sqrt(major / np.maximum(minor, 0.25)), *_ELONGATED)
        * _ramp(aligned, math.cos(math.radians(_ALONG[1])), math.cos(math.radians(_ALONG[0])))
        * _ramp(coherent, *_COHERENT)
    )
    along[0] = 0.0
    return (like * (1.0 - along[labels])).astype(np.float32)


_BED_BLUR = 2.0
"""Gaussian sigma (px) of the intensity the bedding's gradient is read on: a 3 px vein is
faint at it, a contact is not."""
_ELONGATED = (2.5, 4.0)
"""Length over width (standard deviations) from which a patch is a sliver (1 at the upper): a
stain is under 2, cut by a contact about 2."""
_ALONG = (15.0, 25.0)
"""Degrees between a sliver's axis and the beds within which it lies along them (1 below)."""
_COHERENT = (0.3, 0.5)
"""Coherence of the bedding's tensor from which there are beds to lie along (1 above)."""


_JOIN = 0.008
"""Gaussian sigma (share of the diagonal, 3 px at 216x288) pieces of one band join over."""
_JOINED = 0.25
"""Blurred likelihood from which a pixel belongs to a region: a quarter of it flagged."""


def point_kinds(
    points: list[InterestPoint], maps: dict[str, np.ndarray], prefer: str | None = None
) -> list[str]:
    """Each point's kind: the kind (of :data:`KIND_NAMES`, ties in that order) whose mean
    likelihood over the point's core (half its radius, at least 1.5 px, where the explanation
    reads its colour and tone) is highest and at least 0.5, else ``other``; ``prefer`` is the
    kind when a tenth of the core is at least 0.5 of it (``_PREFER``)."""
    kinds = []
    rows, cols = maps["sky"].shape
    for point in points:
        reach = max(0.5 * max(point.radius, 1.0), 1.5)
        r0, r1 = max(0, math.floor(point.y - reach)), min(rows, math.ceil(point.y + reach) + 1)
        c0, c1 = max(0, math.floor(point.x - reach)), min(cols, math.ceil(point.x + reach) + 1)
        yy, xx = np.ogrid[r0:r1, c0:c1]
        core = (yy - point.y) ** 2 + (xx - point.x) ** 2 <= reach**2
        if not core.any():
            kinds.append("other")
            continue
        if prefer is not None and _holds(maps, prefer, (slice(r0, r1), slice(c0, c1)), core):
            kinds.append(prefer)
            continue
        means = {k: float(maps[k][r0:r1, c0:c1][core].mean()) for k in KIND_NAMES}
        best = max(KIND_NAMES, key=lambda k: means[k])
        kinds.append(best if means[best] >= 0.5 else "other")
    return kinds


def _holds(
    maps: dict[str, np.ndarray], kind: str, box: tuple[slice, slice], core: np.ndarray
) -> bool:
    """A tenth of the core is at least 0.5 of ``kind``, and not of the opposite tone too (a
    bright vein across a dark bed is neither a dark nor a bright target by this test)."""
    share = [
        np.percentile(maps[k][box][core], _PREFER) >= 0.5
        for k in (kind, _OPPOSITE.get(kind))
        if k is not None
    ]
    return share[0] and not any(share[1:])


_OPPOSITE = {"dark": "bright", "bright": "dark"}
_PREFER = 90.0
"""A point found on the evidence of one kind is of that kind when a tenth of its core is (a
thin vein crosses its core)."""


def aimed_map(
    segs: tuple[Segmentation, ...],
    params: VisionParams,
    total: np.ndarray,
    texture: np.ndarray | None,
    weight: np.ndarray,
    *,
    prior: np.ndarray | None = None,
    line: np.ndarray | None = None,
) -> InterestMap:
    """``interest.interest_map`` of the evidence weighted per pixel: each of ``total``,
    ``texture`` and ``line`` goes to its typical level (median) where ``weight`` is 0 and
    stays itself where it is 1, before any blur, so what a plant makes uncommon does not
    spread onto the rock beside it."""

    def weigh(m: np.ndarray | None) -> np.ndarray | None:
        if m is None:
            return None
        typical = np.float32(np.median(m[::_LATTICE, ::_LATTICE]))
        return (m - typical) * weight + typical

    return interest_map(segs, params, weigh(total), weigh(texture), prior=prior, line=weigh(line))


_LATTICE = 2
"""The typical level is the median over every other pixel of every other row."""


def aim_points(
    imap: InterestMap,
    params: VisionParams,
    maps: dict[str, np.ndarray] | None = None,
    remap: Callable[[np.ndarray], InterestMap] | None = None,
) -> tuple[list[InterestPoint], list[str]]:
    """The points ordered by ``params.aim``, marked as ``peaks.mark_background`` marks them,
    and each one's kind (:func:`point_kinds`; empty for ``any``).

    ``maps`` are :func:`kind_maps` of the analysed image and ``remap`` gives the interest map
    of the evidence weighted per pixel (:func:`aimed_map`); for ``any`` neither is used and the
    points are ``find_points`` and ``mark_background``'s, untouched. Points found on the
    weighted maps are scored on ``imap`` where they lie, as every other point.
    """
    aim = parse_aim(params.aim)
    science = find_points(imap, params)
    if aim.neutral or not science or maps is None or remap is None:
        return mark_background(imap, science), []
    excluded = [_EXCLUDES[e] for e in sorted(aim.exclude)]
    keep = np.ones(maps["sky"].shape, np.float32)
    for kind in excluded:
        keep *= 1.0 - maps[kind]
    sought: list[InterestPoint] = []
    evidence: list[float] = []  # each sought point's own evidence, the aim's ranking
    if aim.kind != "any" and (maps[aim.kind] >= 0.5).any():  # none of that kind in view
        wanted = maps[aim.kind] * keep
        sought = find_points(remap(wanted), params)
        evidence = [p.score / sought[0].score for p in sought]  # its height there
        if aim.kind in _BY_MASS:
            rows, cols = wanted.shape
            mass = cv2.GaussianBlur(wanted, (0, 0), _MASS * math.hypot(rows, cols))
            evidence = [
                float(mass[min(rows - 1, max(0, round(p.y))), min(cols - 1, max(0, round(p.x)))])
                for p in sought
            ]
        sought = _rescored(imap, sought)
    found, kinds = sought, point_kinds(sought, maps, prefer=aim.kind)
    if excluded:
        rest = _rescored(imap, find_points(remap(keep), params))
        found, kinds = found + rest, kinds + point_kinds(rest, maps)
    found, kinds = found + science, kinds + point_kinds(science, maps)
    # Targets first; then the sought kind, found on its own evidence (by that evidence: the
    # aim's own ranking) before any other point of that kind; then the other kinds and the
    # kinds set aside, by score.
    marked = mark_background(imap, found)
    key = [
        (
            not p.target,
            _group(aim, kind, excluded),
            k >= len(sought),
            -(evidence[k] if k < len(sought) else p.score),
        )
        for k, (p, kind) in enumerate(zip(marked, kinds, strict=True))
    ]
    order = sorted(range(len(found)), key=key.__getitem__)
    chosen: list[int] = []
    for k in order:
        if len(chosen) < params.top_n and not any(_same(found[k], found[j]) for j in chosen):
            chosen.append(k)
    best = len(found) - len(science)  # the science's own best point is always reported
    if not any(_same(found[best], found[j]) for j in chosen):
        chosen[min(len(chosen), params.top_n - 1) :] = [best]
    points = [dataclasses.replace(marked[k], rank=rank) for rank, k in enumerate(chosen, start=1)]
    return points, [kinds[k] for k in chosen]


_BY_MASS = frozenset({"dark", "bright"})
"""Kinds whose points rank by how much of the kind lies around them (a stain's body, a vein's
run before a bed's crumb); a colour ranks by its height on its own evidence (a lichen is
small, and a blue sky's rim large)."""
_MASS = 0.02
"""Gaussian sigma (share of the diagonal, 7 px at 216x288) over which that is summed."""


def _rescored(imap: InterestMap, points: list[InterestPoint]) -> list[InterestPoint]:
    """The points with the score of ``imap`` where they lie (its grid cell)."""
    rows, cols = imap.grid.shape
    f = imap.factor
    return [
        dataclasses.replace(
            p,
            score=float(imap.grid[min(rows - 1, int(p.y) // f), min(cols - 1, int(p.x) // f)]),
        )
        for p in points
    ]


def _group(aim: Aim, kind: str, excluded: list[str]) -> int:
    """0: the kind sought; 1: any other; 2: a kind set aside."""
    if kind in excluded:
        return 2
    return 0 if kind == aim.kind else 1


def _same(a: InterestPoint, b: InterestPoint) -> bool:
    """Two points on one target: either lies within the other's radius."""
    return math.hypot(a.x - b.x, a.y - b.y) < max(a.radius, b.radius, 1.0)


def aim_entry(aim: str, kind: str) -> dict:
    """A point's explanation entry under a non-neutral aim: its kind and whether the aim
    seeks it (``sought``), sets it aside (``set aside``) or neither (``other``).

    >>> aim_entry("dark+no-vegetation", "vegetation")
    {'plane': 'aim', 'aim': 'dark+no-vegetation', 'kind': 'vegetation', 'match': 'set aside'}
    """
    parsed = parse_aim(aim)
    match = ("sought", "other", "set aside")[
        _group(parsed, kind, [_EXCLUDES[e] for e in parsed.exclude])
    ]
    return {"plane": "aim", "aim": parsed.text, "kind": kind, "match": match}
