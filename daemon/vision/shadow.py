"""Shadow likelihood: how much each pixel looks like lit rock of its surroundings in shade.

The seed's authors found their interest maps drawn to "structural shadow": the dark pockets
under ledges of a jagged outcrop are rare in intensity, so the uncommon map ranks them with
the wet stains and veins a geologist wants. Shape alone (``isotropy``) cannot tell a short
shadow from a stain. Colour can, because a shadow changes the light, not the rock:

* it is darker than the lit rock around it;
* its chromaticity is the rock's, moved only along the direction a change of illuminant
  moves it: not at all (shade of a grey overcast) or towards blue (in clear daylight the
  shade is lit by the sky alone, whose light is bluer than the sun's; Finlayson, Hordley,
  Lu & Drew, "On the removal of shadows from images", PAMI 28(1), 2006: in log-chromaticity
  illuminant changes move a surface along one line);
* a material change (a wet stain, whose colour deepens; a plant; a vein) moves it elsewhere.

Each pixel's log colour at a fine scale is compared with the lit rock around it (a
Gaussian average of the pixels not darker than their surroundings, then than that average,
so neither a shadow nor a stain is compared with itself), darkened to the pixel's brightness
as a change of light alone would (``_reference``: in log(value + offset) a darkening also
greys a colour), and with that average taken a little above, below, left and right of it
(``_SIDE``): a ledge shadow cast across a bed contact is the shade of one bed at its
top and of the other at its bottom, and the mixture of both is neither. The best of the
five comparisons counts. The likelihood is darkness x purity x tint evidence:

* darkness: the log brightness deficit, 1 from ``_DARK`` (1.5 times darker);
* purity: how close the chromaticity shift lies to the illuminant line (a cone around it);
* tint evidence: 1 for a shift towards blue by ``_TINT``; on rock coloured enough that a
  change of material would have shown (``_HOST_CHROMA``), 1 for any shift from none
  towards blue. On grey rock, or in a grey image, a darker patch with no colour of its own
  is as likely a dark material (a wet stain on grey gypsum, a crack) and gets no shadow
  evidence unless it turns blue.

Two shape rules finish it. An untinted dark line thinner than ``_THIN`` is a crack or a
vein, not the shadow of a ledge (a ledge deep enough to matter casts a band): it is opened
away. A thin line that turns blue stays: a ledge shadow seen from afar is as thin as a crack,
and the sky's tint says what it is. The opening sees the evidence at the fine scale, where a
2-3 px crack, blurred and saturated, reads as 6-7 px of shade and survives it; so lines are
also looked for at a crack's own scale (``_dark_lines``): a connected patch darker than its
lit rock by ``_DARK`` at ``_CRACK``, in which no disc of radius ``_THIN`` fits, loses its
untinted evidence. A patch that holds such a disc anywhere is a shadow's body with its
tapering ends, and stays shade whole. What remains is widened by ``_EDGE``, because a shadow's
edge, half lit at the fine scale, is as rare in intensity as its core and would otherwise
keep a ring of interest around every gated shadow.

Shade too wide for the surround (a ledge's shadow seen close, tens of pixels thick) is
found the same way on a copy ``_WIDE`` times smaller, and kept where its patch is elongated
(``_LONG``): a ledge's shadow runs along the ledge; a round dark hollow may be the target.

What it cannot see: an untinted shadow on grey rock, and a dark grey target that happens to
sit on the illuminant line of its host. For speed, the side comparisons are made only where a
pixel is darker than its surroundings' mean, the surroundings are blurred on a grid of 2 x 2
means (``grid.surround``) and the wide scale is judged on a grid of 4 x 4.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .exact import exact
from .grid import block_means, block_pair, expand, grid_blur, surround, surround_grid
from .kernels import kernel
from .params import VisionParams

__all__ = ["shadow_likelihood"]

_OFFSET = 8.0
"""Log colour is taken of the 8-bit value + 8: sensor noise in near-black pixels is not blown
up into large log ratios."""
_LOGS = exact(cv2.log)(np.arange(256, dtype=np.float32) + np.float32(_OFFSET)).reshape(1, 256)
"""log(value + ``_OFFSET``) of each 8-bit value, float32: a lookup is one pass where the
conversion, the sum and the logarithm were three, and gives the same values."""
_MEAN = np.full((1, 3), 1.0 / 3.0, np.float32)
"""Log brightness: the mean of the three log channels."""
_FINE = 1.5
"""Gaussian sigma (analysed pixels) of a pixel's own colour: sensor noise averaged, a
ledge shadow a few pixels thick kept."""
_LIT = 0.15
"""Pixels more than this log brightness below their surroundings are not lit rock."""
_DARK = 0.4
"""Log brightness deficit at which darkness counts fully (1.5 times darker)."""
_TINT = 0.15
"""Shift towards blue along the illuminant line at which the tint evidence is full."""
_UNTINTED = (0.015, 0.045)
"""On coloured rock, a shift along the line from this far on the warm side (sensor noise
about a pure darkening) up counts fully, and fades to nothing this far: a wet stain deepens
its rock's colour, away from blue (0.06 on grey shale, 0.1-0.6 on coloured beds)."""
_CONE = (0.04, 0.3)
"""Purity: a shift counts as an illuminant change while its distance from the line is below
0.04 + 0.3 x its length along it, falling linearly to 0 there."""
_SIDE = 5.0 / 3.0
"""The side comparisons look this many ``shadow_surround`` sigmas away: past the contact a
shadow straddles, within the bed on either side."""
_CANDIDATE = 0.25
"""Darkness against the surroundings' mean (a 0.1 log deficit) below which no side is looked
at: a shadow straddling a contact is darker than the mixture of its two beds."""
_CRACK = 0.7
"""Gaussian sigma (analysed pixels) at which a crack is measured for ``_dark_lines``: the
segmentation's own pre-smoothing, enough to bridge sensor noise in a 1.5-px line and not
enough to widen a 3-px one past the opening."""
_THIN = 2
"""Radius (analysed pixels) of the opening: untinted dark lines up to 2 x 2 + 1 = 5 px thick
are not shadows."""
_EDGE = 2
"""Radius (analysed pixels) the likelihood is widened by: the reach of the fine scale's blur."""
_WIDE = 4
"""The second scale's reduction: a surround 4 times wider, for shade too wide for the first
(a ledge's shadow seen from 60 m is 20-70 analysed pixels thick)."""
_WIDE_MIN = 16
"""Images under 16 x ``_WIDE`` pixels on a side have no second scale."""
_LONG = 2.0
"""At the second scale only patches this many times longer than wide count as shade: a
ledge's shadow runs along its ledge, while a round dark hollow seen close up (the shadowed
core of a stain at 10 m) is a target."""
_HOST_CHROMA = 0.06
"""Log spread between the surroundings' brightest and dimmest channel below which rock is too
grey for an untinted darkening to tell shade from a dark material; full evidence at twice."""


def shadow_likelihood(bgr: np.ndarray, params: VisionParams) -> np.ndarray:
    """Per-pixel likelihood (0..1) that a pixel is shaded rock of its surroundings,
    (M, N) float32.

    Examples
    --------
    >>> from cyborg.daemon.vision.params import DEFAULT
    >>> img = np.full((60, 80, 3), (60, 80, 150), np.uint8)        # red sandstone
    >>> img[28:34, 10:70] = (60 * 0.5, 80 * 0.41, 150 * 0.36)      # in the sky's shade
    >>> img[10:16, 30:36] = (40, 110, 40)                          # a darker green plant
    >>> shade = shadow_likelihood(img, DEFAULT)
    >>> bool(shade[31, 40] > 0.8), round(float(shade[13, 33]), 2)
    (True, 0.0)
    >>> grey = np.full((60, 80, 3), 120, np.uint8)
    >>> grey[28:34, 10:70] = 50                                    # a dark band on grey
    >>> float(shadow_likelihood(grey, DEFAULT).max())
    0.0
    """
    shade = _likelihood(bgr, params)
    rows, cols = shade.shape
    if min(rows, cols) >= _WIDE_MIN * _WIDE:
        wide = _elongated(_likelihood(block_means(bgr, _WIDE), params))
        shade = cv2.max(shade, expand(wide, _WIDE, (rows, cols)))
    return shade


def _likelihood(bgr: np.ndarray, params: VisionParams) -> np.ndarray:
    """The likelihood at one scale: the surround ``params.shadow_surround`` pixels of ``bgr``."""
    logs = cv2.LUT(bgr, _LOGS)
    sigma = params.shadow_surround
    own = cv2.GaussianBlur(logs, (0, 0), _FINE)
    shape = bgr.shape[:2]
    brightness = cv2.transform(own, _MEAN)
    level = cv2.transform(logs, _MEAN)
    around = expand(*surround(level, sigma), shape)
    # Lit rock is what is not much darker than its surroundings' mean, then than the lit
    # rock's own mean: a stain or a shadow twice the surround wide is most of its own
    # surroundings, and once left out it no longer dims the rock it is compared with.
    host = _lit_mean(logs, brightness, around, sigma)
    host = _lit_mean(logs, brightness, cv2.transform(host, _MEAN), sigma)
    # The shift from the lit rock: darkness, and the chromaticity shift along and across the
    # illuminant line (exactly 0 in a grey image) from the host darkened to the pixel; where
    # a pixel is darker than its surroundings' mean, also from the side hosts.
    tinted, untinted = _shade(own, host, params.shadow_tint, max(1, round(_SIDE * sigma)))
    untinted = cv2.morphologyEx(untinted, cv2.MORPH_OPEN, _disc(_THIN))
    crack = cv2.GaussianBlur(level, (0, 0), _CRACK)
    lines = _dark_lines(cv2.subtract(cv2.transform(host, _MEAN), crack))
    return cv2.dilate(_either(tinted, untinted, lines), _disc(_EDGE))


@kernel
def _either(tinted: np.ndarray, untinted: np.ndarray, lines: np.ndarray) -> np.ndarray:
    """The larger of the tinted and the untinted evidence, the untinted taken as 0 on
    ``lines``, float32: the mask and the maximum in one pass."""
    out = np.empty(tinted.shape, np.float32)
    zero = np.float32(0.0)
    for y in range(tinted.shape[0]):
        for x in range(tinted.shape[1]):
            other = zero if lines[y, x] else untinted[y, x]
            out[y, x] = tinted[y, x] if tinted[y, x] >= other else other
    return out


def _dark_lines(deficit: np.ndarray) -> np.ndarray:
    """uint8 mask of dark lines standing alone, widened by ``_EDGE``: the connected patches
    of ``deficit`` (log brightness below the lit rock) above ``_DARK`` that no disc of radius
    ``_THIN`` fits in anywhere."""
    dark = (deficit > np.float32(_DARK)).astype(np.uint8)
    n, labels = cv2.connectedComponents(dark, connectivity=8)
    if n <= 1:
        return np.zeros_like(dark)
    opened = cv2.morphologyEx(dark, cv2.MORPH_OPEN, _disc(_THIN))
    return cv2.dilate(_thin_patches(labels, opened, n), _disc(_EDGE))


@kernel
def _thin_patches(labels: np.ndarray, opened: np.ndarray, n: int) -> np.ndarray:
    """uint8 mask of the pixels of the ``n - 1`` labelled patches (label 0: none) that hold
    no pixel of ``opened``."""
    body = np.zeros(n, np.bool_)
    for y in range(labels.shape[0]):
        for x in range(labels.shape[1]):
            if opened[y, x]:
                body[labels[y, x]] = True
    out = np.zeros(labels.shape, np.uint8)
    for y in range(labels.shape[0]):
        for x in range(labels.shape[1]):
            label = labels[y, x]
            if label > 0 and not body[label]:
                out[y, x] = 1
    return out


def _lit_mean(
    logs: np.ndarray, brightness: np.ndarray, level: np.ndarray, sigma: float
) -> np.ndarray:
    """Mean log colour of the pixels within ``_LIT`` of ``level`` or brighter (their blurred
    sum over their blurred weight), at every pixel."""
    f = surround_grid(logs.shape, sigma)
    if f == 2:  # straight to the grid's 2 x 2 means: the full-size weighted copy never made
        both = grid_blur(_lit_blocks(logs, brightness, level), sigma, f)
    else:
        both, f = surround(_lit_weighted(logs, brightness, level), sigma)
    return expand(_weighted_mean(both), f, logs.shape[:2])


@kernel
def _lit_blocks(logs: np.ndarray, brightness: np.ndarray, level: np.ndarray) -> np.ndarray:
    """``block_means(_lit_weighted(...), 2)`` in one pass, bit for bit: each 2 x 2 block's
    four values (``block_pair``) summed as OpenCV's area reduction of four channels sums
    them."""
    rows, cols = brightness.shape
    out = np.empty(((rows + 1) // 2, (cols + 1) // 2, 4), np.float32)
    quarter, zero = np.float32(0.25), np.float32(0.0)
    block = np.empty((2, 2, 4), np.float32)
    for by in range(out.shape[0]):
        ys = block_pair(by, rows)
        for bx in range(out.shape[1]):
            xs = block_pair(bx, cols)
            for i, y in enumerate(ys):
                for j, x in enumerate(xs):
                    lit = brightness[y, x] - level[y, x] > np.float32(-_LIT)
                    for k in range(3):
                        block[i, j, k] = logs[y, x, k] if lit else zero
                    block[i, j, 3] = np.float32(1.0) if lit else zero
            for k in range(4):
                pair = (block[0, 0, k] + block[0, 1, k]) + (block[1, 0, k] + block[1, 1, k])
                out[by, bx, k] = pair * quarter
    return out


@kernel
def _lit_weighted(logs: np.ndarray, brightness: np.ndarray, level: np.ndarray) -> np.ndarray:
    """(M, N, 4) float32: the log colour of the pixels within ``_LIT`` of ``level`` or
    brighter (0 elsewhere), and that weight (1 or 0)."""
    rows, cols = brightness.shape
    out = np.zeros((rows, cols, 4), np.float32)
    for y in range(rows):
        for x in range(cols):
            if brightness[y, x] - level[y, x] > np.float32(-_LIT):
                out[y, x, 0], out[y, x, 1], out[y, x, 2] = (
                    logs[y, x, 0],
                    logs[y, x, 1],
                    logs[y, x, 2],
                )
                out[y, x, 3] = 1.0
    return out


@kernel
def _weighted_mean(both: np.ndarray) -> np.ndarray:
    """(m, n, 3) float32: blurred weighted sums over their blurred weight (+ 1e-3, so an
    area with no lit pixel is no division by 0)."""
    rows, cols = both.shape[:2]
    out = np.empty((rows, cols, 3), np.float32)
    for y in range(rows):
        for x in range(cols):
            weight = both[y, x, 3] + np.float32(1e-3)
            for k in range(3):
                out[y, x, k] = both[y, x, k] / weight
    return out


def _elongated(shade: np.ndarray) -> np.ndarray:
    """``shade`` where its patches (above one half) are at least ``_LONG`` times longer than
    they are wide (second moments of each connected patch), 0 elsewhere."""
    n, labels = cv2.connectedComponents((shade > 0.5).astype(np.uint8), connectivity=8)
    if n <= 1:
        return np.zeros_like(shade)
    ys, xs = np.nonzero(labels)
    which = labels[ys, xs]
    count = np.bincount(which, minlength=n).clip(1).astype(np.float64)
    dy = ys - (np.bincount(which, ys, n) / count)[which]
    dx = xs - (np.bincount(which, xs, n) / count)[which]
    syy = np.bincount(which, dy * dy, n) / count + 1.0 / 12.0  # + a pixel's own spread
    sxx = np.bincount(which, dx * dx, n) / count + 1.0 / 12.0
    sxy = np.bincount(which, dx * dy, n) / count
    half = (sxx + syy) / 2.0
    spread = np.sqrt(np.maximum(half * half - (sxx * syy - sxy * sxy), 0.0))
    long = half + spread >= _LONG**2 * (half - spread)
    long[0] = False
    return shade * long[labels].astype(np.float32)


def _disc(radius: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))


@kernel
def _clip01(x: float) -> float:
    return min(max(x, 0.0), 1.0)


@kernel
def _against(mine: tuple, own: float, host: tuple, lin: tuple, u: tuple) -> tuple[float, float]:
    """(tinted, untinted) evidence of a pixel against a host, from the pixel's darkness and
    chromaticity along and across the illuminant line ``u`` (``mine``), its mean linear
    value (``own``) and the host's log colour (B, G, R) and linear values (``lin``). The host
    is taken as it would be darkened to the pixel's own brightness by a change of light alone.

    Log colour is taken of the value + ``_OFFSET``, and the offset weighs more the darker a
    pixel: darkened uniformly, a warm rock's log colour greys, which reads as a shift towards
    blue (0.07 at half brightness). Compared with the host darkened the same way, a pure
    darkening shifts by nothing, sky shade towards blue, and a wet stain, whose colour
    deepens, away from it."""
    darkness = mine[0] + (host[0] + host[1] + host[2]) / (3.0 * _DARK)
    if darkness <= 0.0:  # not darker than this rock: no evidence, whatever the colour
        return 0.0, 0.0
    darker = _clip01(own / ((lin[0] + lin[1] + lin[2]) / 3.0 + 1e-3))
    red = lin[2] * darker + _OFFSET  # log ratios to red: two logarithms where three were
    db = math.log((lin[0] * darker + _OFFSET) / red)
    dg = math.log((lin[1] * darker + _OFFSET) / red)
    along = mine[1] - (db * u[0] + dg * u[1])
    across = mine[2] - (dg * u[0] - db * u[1])
    purity = 1.0 - abs(across) / (abs(along) * _CONE[1] + _CONE[0])
    dark = _clip01(darkness) * _clip01(purity)
    tinted = _clip01(along / _TINT)
    chroma = max(host[0], host[1], host[2]) - min(host[0], host[1], host[2])
    coloured = _clip01(chroma / _HOST_CHROMA - 1.0)  # an untinted darkening needs colour
    untinted = _clip01((along + _UNTINTED[1]) / (_UNTINTED[1] - _UNTINTED[0])) * coloured
    return dark * tinted, dark * untinted


def _shade(
    own: np.ndarray, host: np.ndarray, tint: tuple[float, float], d: int
) -> tuple[np.ndarray, np.ndarray]:
    """Tinted and untinted evidence, (M, N) float32 each, of every pixel's own log colour
    against its lit rock's (``host``), and where the pixel is darker than that rock by
    ``_CANDIDATE``, also against the rock ``d`` pixels to each side (clipped into the
    frame): the best of the five comparisons counts. ``tint`` is the illuminant line."""
    u = tuple(float(t) / math.hypot(*tint) for t in tint)
    # Linear values by OpenCV's vector exp: the kernel's scalar one costs 5x more.
    lin_own = cv2.subtract(cv2.transform(cv2.exp(own), _MEAN), _OFFSET)
    lin_host = cv2.subtract(cv2.exp(host), (_OFFSET,) * 3)
    return _shade_kernel((own, host), (lin_own, lin_host), u, d)


@kernel
def _shade_kernel(logs: tuple, lin: tuple, u: tuple, d: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_shade` of the log colours ``logs`` (own, host) and the linear values
    ``lin`` (own's mean, host's)."""
    (own, host), (own_lin, host_lin) = logs, lin
    rows, cols = own.shape[:2]
    tinted = np.zeros((rows, cols), np.float32)
    untinted = np.zeros((rows, cols), np.float32)
    for y in range(rows):
        for x in range(cols):
            o0, o1, o2 = own[y, x, 0], own[y, x, 1], own[y, x, 2]
            h = (host[y, x, 0], host[y, x, 1], host[y, x, 2])
            hl = (host_lin[y, x, 0], host_lin[y, x, 1], host_lin[y, x, 2])
            db, dg = o0 - o2, o1 - o2  # log(B / R), log(G / R)
            mine = (-(o0 + o1 + o2) / (3.0 * _DARK), db * u[0] + dg * u[1], dg * u[0] - db * u[1])
            darkness = mine[0] + (h[0] + h[1] + h[2]) / (3.0 * _DARK)
            if darkness <= 0.0:  # no darker than its rock: no evidence, and no side is looked at
                continue
            best = _against(mine, own_lin[y, x], h, hl, u)
            if darkness > _CANDIDATE:
                for dy, dx in ((0, d), (0, -d), (d, 0), (-d, 0)):
                    sy, sx = min(max(y - dy, 0), rows - 1), min(max(x - dx, 0), cols - 1)
                    side = (host[sy, sx, 0], host[sy, sx, 1], host[sy, sx, 2])
                    bound = _clip01(mine[0] + (side[0] + side[1] + side[2]) / (3.0 * _DARK))
                    if bound <= best[0] and bound <= best[1]:
                        continue  # its evidence is at most its darkness: it cannot be better
                    side_lin = (host_lin[sy, sx, 0], host_lin[sy, sx, 1], host_lin[sy, sx, 2])
                    other = _against(mine, own_lin[y, x], side, side_lin, u)
                    best = (max(best[0], other[0]), max(best[1], other[1]))
            tinted[y, x], untinted[y, x] = best
    return tinted, untinted
