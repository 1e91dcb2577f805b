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

from .grid import block_means, expand, surround
from .params import VisionParams

__all__ = ["shadow_likelihood"]

_OFFSET = 8.0
"""Log colour is taken of the 8-bit value + 8: sensor noise in near-black pixels is not blown
up into large log ratios."""
_MEAN = np.full((1, 3), 1.0 / 3.0, np.float32)
"""Log brightness: the mean of the three log channels."""
_FINE = 1.5
"""Gaussian sigma (analysed pixels) of a pixel's own colour: sensor noise averaged, a
ledge shadow a few pixels thick kept."""
_LIT = 0.15
"""Pixels more than this log brightness below their surroundings are not lit rock."""
_DARK = 0.4
"""Log brightness deficit at which darkness counts fully (1.5 times darker)."""
_SPLIT = np.array([[-1.0 / (3.0 * _DARK)] * 3, [1.0, 0.0, -1.0], [0.0, 1.0, -1.0]], np.float32)
"""A log colour shift to darkness (1 at ``_DARK``), log(B / R) and log(G / R) shifts."""
_SPLIT_ROWS = tuple(np.ascontiguousarray(_SPLIT[k : k + 1]) for k in range(3))
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
    logs = cv2.log(bgr.astype(np.float32) + np.float32(_OFFSET))
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
    # illuminant line (exactly 0 in a grey image) from the host darkened to the pixel.
    mine = _project(own, params.shadow_tint)
    ref = _reference(host, own, params.shadow_tint)
    blue, green, red = cv2.split(host)
    chroma = cv2.max(cv2.max(blue, green), red) - cv2.min(cv2.min(blue, green), red)
    coloured = np.clip(chroma * np.float32(1.0 / _HOST_CHROMA) - 1.0, 0.0, 1.0)
    tinted, untinted = _score(mine, ref, coloured)
    # The sides matter only where a pixel is darker than its surroundings' mean: scored
    # there alone, on the side hosts' pixels (row, col moved, clipped into the frame).
    rows, cols = tinted.shape
    dark = np.flatnonzero(cv2.subtract(mine[0], ref[0]) > np.float32(_CANDIDATE))
    if dark.size:
        # OpenCV reads an array of <= 4 values as a scalar: a few candidates are repeated.
        dark = np.resize(dark, max(dark.size, 8))
        at = [m.reshape(-1)[dark] for m in mine]
        own_at = own.reshape(-1, 3)[dark][:, None]
        row, col = np.divmod(dark, cols)
        best = [tinted.reshape(-1)[dark], untinted.reshape(-1)[dark]]
        d = max(1, round(_SIDE * sigma))
        for dy, dx in ((0, d), (0, -d), (d, 0), (-d, 0)):
            side = np.clip(row - dy, 0, rows - 1) * cols + np.clip(col - dx, 0, cols - 1)
            host_at = host.reshape(-1, 3)[side][:, None]
            side_ref = [m.reshape(-1) for m in _reference(host_at, own_at, params.shadow_tint)]
            scores = _score(at, side_ref, coloured.reshape(-1).take(side))
            best = [np.maximum(b, s.reshape(-1)) for b, s in zip(best, scores, strict=True)]
        tinted.reshape(-1)[dark], untinted.reshape(-1)[dark] = best
    untinted = cv2.morphologyEx(untinted, cv2.MORPH_OPEN, _disc(_THIN))
    crack = cv2.GaussianBlur(level, (0, 0), _CRACK)
    lines = _dark_lines(cv2.subtract(cv2.transform(host, _MEAN), crack))
    untinted[lines > 0] = 0.0
    return cv2.dilate(cv2.max(tinted, untinted), _disc(_EDGE))


def _dark_lines(deficit: np.ndarray) -> np.ndarray:
    """uint8 mask of dark lines standing alone, widened by ``_EDGE``: the connected patches
    of ``deficit`` (log brightness below the lit rock) above ``_DARK`` that no disc of radius
    ``_THIN`` fits in anywhere."""
    dark = (deficit > np.float32(_DARK)).astype(np.uint8)
    n, labels = cv2.connectedComponents(dark, connectivity=8)
    if n <= 1:
        return np.zeros_like(dark)
    body = np.zeros(n, np.uint8)
    body[labels[cv2.morphologyEx(dark, cv2.MORPH_OPEN, _disc(_THIN)) > 0]] = 1
    return cv2.dilate(dark - body[labels], _disc(_EDGE))


def _lit_mean(
    logs: np.ndarray, brightness: np.ndarray, level: np.ndarray, sigma: float
) -> np.ndarray:
    """Mean log colour of the pixels within ``_LIT`` of ``level`` or brighter (their blurred
    sum over their blurred weight), at every pixel."""
    lit = (cv2.subtract(brightness, level) > -_LIT).astype(np.float32)
    weighted = cv2.merge([cv2.multiply(logs, cv2.merge([lit] * 3)), lit])
    both, f = surround(weighted, sigma)
    weight = cv2.merge([both[..., 3] + np.float32(1e-3)] * 3)
    return expand(cv2.divide(both[..., :3], weight), f, logs.shape[:2])


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


def _project(logs: np.ndarray, tint: tuple[float, float]) -> list[np.ndarray]:
    """Log B, G, R to darkness (1 at ``_DARK``) and the chromaticity along and across the
    illuminant line ``tint``: exactly 0 on a grey pixel, so a grey image has no evidence."""
    # One single-channel transform per row: a 3-channel transform then a split costs 3x.
    darkness, db, dg = (cv2.transform(logs, row) for row in _SPLIT_ROWS)
    u0, u1 = np.asarray(tint, np.float64) / math.hypot(*tint)
    return [darkness, cv2.addWeighted(db, u0, dg, u1, 0.0), cv2.addWeighted(dg, u0, db, -u1, 0.0)]


def _reference(host: np.ndarray, own: np.ndarray, tint: tuple[float, float]) -> list[np.ndarray]:
    """The host's (darkness, along, across), its chromaticity taken as it would be darkened
    to the pixel's own brightness by a change of light alone.

    Log colour is taken of the value + ``_OFFSET``, and the offset weighs more the darker a
    pixel: darkened uniformly, a warm rock's log colour greys, which reads as a shift towards
    blue (0.07 at half brightness). Compared with the host darkened the same way, a pure
    darkening shifts by nothing, sky shade towards blue, and a wet stain, whose colour
    deepens, away from it."""
    lin_host = cv2.exp(host) - np.float32(_OFFSET)
    lin_own = cv2.exp(own) - np.float32(_OFFSET)
    ratio = cv2.transform(lin_own, _MEAN) / (cv2.transform(lin_host, _MEAN) + np.float32(1e-3))
    darker = np.clip(ratio, 0.0, 1.0)
    darkened = cv2.log(lin_host * darker[..., None] + np.float32(_OFFSET))
    return [_project(host, tint)[0], *_project(darkened, tint)[1:]]


def _score(
    mine: list[np.ndarray], host: list[np.ndarray], coloured: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Shadow likelihood of each pixel's (darkness, along, across) against a host's, on the
    tinted evidence and on the untinted; ``coloured`` is how coloured that host is (0..1),
    which the untinted evidence needs."""
    darkness, along, across = (cv2.subtract(a, b) for a, b in zip(mine, host, strict=True))
    cone = cv2.add(cv2.absdiff(along, 0.0) * np.float32(_CONE[1]), _CONE[0])
    purity = 1.0 - cv2.divide(cv2.absdiff(across, 0.0), cone)
    dark = cv2.multiply(np.clip(darkness, 0.0, 1.0), np.clip(purity, 0.0, 1.0))
    tinted = np.clip(along * np.float32(1.0 / _TINT), 0.0, 1.0)
    untinted = cv2.multiply(
        np.clip(
            (along + np.float32(_UNTINTED[1])) * np.float32(1.0 / (_UNTINTED[1] - _UNTINTED[0])),
            0.0,
            1.0,
        ),
        coloured,
    )
    return cv2.multiply(dark, tinted), cv2.multiply(dark, untinted)
