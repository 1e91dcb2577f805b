"""Line rarity: thin bright or dark lines (veins, cracks), and not the steps between beds.

A vein or a crack is a *bar*: a thin strip brighter or darker than the rock on both sides of
it. The texture term's local contrast cannot say so: a contact between two smooth beds, a
step, has as much contrast as a vein, and on an outcrop there are more contacts than veins.
Here
each pixel is compared with the rock on both sides of a short segment through it, at eight
orientations: the bar contrast is the *smaller* of the two differences, centre minus left and
centre minus right, when both have one sign (``bar_contrast``). At a step one side is the
pixel's own surface, so the smaller difference is zero however strong the step; at a vein
both sides differ. It is measured on log intensity, so a vein counts by how many times
brighter or darker than its rock it is, and put in robust standard deviations of the image's
own bar contrast (the median absolute deviation: most pixels are on no line, and grain sets
the noise), so a line is rare against the grain it is drawn in.

A ledge shadow's thin ends and rims are dark bars too. The shadow gate (``shadow``) keeps its
opening of thin untinted lines (a crack is not a shadow), so a shadow's tapered end escapes
it; here a line inherits the shade of what it touches (``line_shade``): a connected line
whose pixels lie, on average, more than half in shade (widened by ``_SHADE_REACH``) is all
shade, so it neither scores nor splits one shadow into two points.
"""

from __future__ import annotations

import functools
import math

import cv2
import numpy as np

from .exact import exact
from .kernels import kernel
from .order import median
from .params import VisionParams

__all__ = ["bar_contrast", "line_rarity", "line_shade"]

_ORIENTATIONS = 8
"""Segment directions tried, every 22.5 degrees: a 4 px half-segment strays from a line
lying between two of them by at most 0.8 px at its ends."""
_FLOOR = 0.1
"""Intensities (0..1) are taken as log(I + 0.1), as the texture term's brightness is."""
_LOGS = exact(cv2.log)(
    np.arange(256, dtype=np.float32) * np.float32(1.0 / 255.0) + np.float32(_FLOOR)
).reshape(1, 256)
"""log(I + ``_FLOOR``) of each 8-bit grey value, float32: looked up, one pass where the
conversion, the scaling, the sum and the logarithm were four, with the same values."""
_SAMPLE = 1 << 14
"""Most pixels (on a regular lattice) the robust scale is estimated on: a median needs few."""
_MAD_FLOOR = 1e-4
"""Smallest robust scale (log intensity): a noiseless flat image has no lines, not
infinitely rare ones."""
_SHADE_REACH = 2
"""Pixels a line's shade is widened by: the rim of a shadow lies just outside it."""
_LINE_Z2 = 9.0
"""Squared robust standard deviations above which a pixel belongs to a line when lines are
told apart (``line_shade``)."""


@functools.lru_cache(maxsize=64)
def _segment_kernel(step: int, half: float) -> np.ndarray:
    """A kernel averaging a segment of half-length ``half`` through its centre in direction
    ``step`` x pi / ``_ORIENTATIONS`` from the x axis, with bilinear taps; (2 ceil(half) + 1)
    square (cached: read-only)."""
    theta = math.pi * step / _ORIENTATIONS
    c, s = math.cos(theta), math.sin(theta)
    r = math.ceil(half)
    kernel = np.zeros((2 * r + 3, 2 * r + 3), np.float32)  # a margin for zero-weight taps
    for t in np.linspace(-half, half, int(4 * half) + 1):
        x, y = r + 1 + t * c, r + 1 + t * s
        x0, y0 = math.floor(x), math.floor(y)
        fx, fy = x - x0, y - y0
        kernel[y0 : y0 + 2, x0 : x0 + 2] += np.array(
            [[(1 - fx) * (1 - fy), fx * (1 - fy)], [(1 - fx) * fy, fx * fy]], np.float32
        )
    kernel = kernel[1:-1, 1:-1] / kernel.sum()
    kernel.flags.writeable = False
    return kernel


def bar_contrast(plane: np.ndarray, width: float, half_length: float) -> np.ndarray:
    """Signed bar contrast of a float32 plane, (M, N) float32: + for a bright line, - for a
    dark one, 0 on a step or flat ground.

    The plane is smoothed at 0.6 ``width``; at each orientation the mean along a segment of
    ``half_length`` through the pixel is compared with the same means 2 ``width`` + 1 pixels
    to either side across it (rounded to whole pixels), and the smaller difference counts.
    One small sparse kernel per orientation, the sides read off its result shifted: a 9 x 9
    segment costs OpenCV a few taps a pixel (2.5 ms for all eight at the 0.13 MP working
    size), where three offset segments each would need kernels past 11 x 11, which OpenCV
    filters through the Fourier transform (over 100 ms).

    Examples
    --------
    >>> plane = np.zeros((40, 40), np.float32)
    >>> plane[:, 20:] = 1.0                              # a step: no line
    >>> float(np.abs(bar_contrast(plane, 1.0, 4.0)).max()) < 1e-6
    True
    >>> plane[:] = 0.0
    >>> plane[:, 19:21] = 1.0                            # a bright line 2 px wide
    >>> c = bar_contrast(plane, 1.0, 4.0)
    >>> bool(c[20, 20] > 0.5), bool(abs(c[20, 10]) < 1e-6)
    (True, True)
    >>> bool(bar_contrast(-plane, 1.0, 4.0)[20, 20] < -0.5)     # a dark one
    True
    """
    rows, cols = plane.shape
    side = 2.0 * width + 1.0
    e = math.ceil(side)
    smooth = cv2.GaussianBlur(plane, (0, 0), 0.6 * width)
    padded = cv2.copyMakeBorder(smooth, e, e, e, e, cv2.BORDER_REPLICATE)
    bright = np.zeros((rows, cols), np.float32)
    dark = np.zeros((rows, cols), np.float32)
    for i in range(_ORIENTATIONS):
        theta = math.pi * i / _ORIENTATIONS
        mean = cv2.filter2D(padded, -1, _segment_kernel(i, half_length))
        dy, dx = round(side * math.cos(theta)), round(-side * math.sin(theta))
        _strongest_bar(mean, e, (dy, dx), bright, dark)
    return _signed(bright, dark)


@kernel
def _strongest_bar(
    mean: np.ndarray, e: int, side: tuple[int, int], bright: np.ndarray, dark: np.ndarray
) -> None:
    """``bright`` and ``dark`` raised, in place, to one orientation's bar contrast: its
    segment means ``mean`` (padded by ``e``) at each pixel against those ``side`` (dy, dx) to
    either side; float32, operation for operation as the whole-array expression."""
    (dy, dx), (rows, cols) = side, bright.shape
    for y in range(rows):  # row slices: a loop over them is vectorised, 2-D indexing is not
        centre = mean[y + e, e : e + cols]
        one = mean[y + e - dy, e - dx : e - dx + cols]
        other = mean[y + e + dy, e + dx : e + dx + cols]
        up, down = bright[y], dark[y]
        for x in range(cols):  # as cv2.max and cv2.min: no NaN here, ties the same value
            a, b = one[x], other[x]
            rise, fall = centre[x] - (a if a >= b else b), (b if a >= b else a) - centre[x]
            up[x] = rise if rise > up[x] else up[x]
            down[x] = fall if fall > down[x] else down[x]


@kernel
def _signed(bright: np.ndarray, dark: np.ndarray) -> np.ndarray:
    """``bright`` where it is at least ``dark``, else ``-dark``."""
    out = np.empty_like(bright)
    for y in range(bright.shape[0]):
        for x in range(bright.shape[1]):
            out[y, x] = bright[y, x] if bright[y, x] >= dark[y, x] else -dark[y, x]
    return out


def line_rarity(bgr: np.ndarray, params: VisionParams) -> np.ndarray:
    """Signed bar contrast of the log intensity in robust standard deviations of the image's
    own, (M, N) float32 (+ bright, - dark lines): its square is the line rarity.

    Examples
    --------
    >>> from cyborg.daemon.vision.params import DEFAULT
    >>> rng = np.random.default_rng(0)
    >>> img = rng.normal(90, 3, (80, 80, 3)).clip(0, 255).astype(np.uint8)
    >>> img[:, 40:] += 60                                # a bed contact
    >>> img[10:70, 19:21] = 200                          # a calcite vein
    >>> z = line_rarity(img, DEFAULT)
    >>> bool(z[40, 20] > 20), bool(abs(z[40, 40]) < 5)
    (True, True)
    """
    plane = cv2.LUT(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY), _LOGS)
    bar = bar_contrast(plane, params.line_width, params.line_length)
    step = max(1, math.isqrt(bar.size // _SAMPLE))
    sample = np.abs(bar[::step, ::step])
    centre = float(median(sample))
    scale = max(1.4826 * float(median(np.abs(sample - centre))), _MAD_FLOOR)
    return _in_scale(bar, np.float32(centre), np.float32(1.0 / scale))


@kernel
def _in_scale(bar: np.ndarray, centre: np.float32, inverse: np.float32) -> np.ndarray:
    """max(|bar| - centre, 0) x inverse with the sign of ``bar``, float32."""
    out = np.empty_like(bar)
    zero = np.float32(0.0)
    for y in range(bar.shape[0]):
        for x in range(bar.shape[1]):
            out[y, x] = math.copysign(max(abs(bar[y, x]) - centre, zero) * inverse, bar[y, x])
    return out


def line_shade(rarity: np.ndarray, shade: np.ndarray) -> np.ndarray:
    """How much each pixel's line is a shadow's, (M, N) float32 in 0..1: the shade likelihood
    widened by ``_SHADE_REACH`` px, raised on each connected line (squared rarity above
    ``_LINE_Z2``) to twice its mean over the line.

    Examples
    --------
    >>> rare = np.zeros((30, 60), np.float32)
    >>> rare[10, 5:55] = 100.0                           # one line...
    >>> shade = np.zeros((30, 60), np.float32)
    >>> shade[8:13, 5:40] = 1.0                          # ...mostly along a shadow
    >>> gate = line_shade(rare, shade)
    >>> float(gate[10, 50]), float(gate[25, 50])         # its far end too; not the rock
    (1.0, 0.0)
    """
    size = 2 * _SHADE_REACH + 1
    wide = cv2.dilate(shade, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size)))
    on = (rarity > _LINE_Z2).astype(np.uint8)
    count, labels = cv2.connectedComponents(on, None, 8)
    if count <= 1 or not wide.any():
        return wide
    # Only line pixels change: a few per cent of the image, indexed rather than mapped.
    at = np.flatnonzero(on)
    which = labels.reshape(-1)[at]
    shade = wide.reshape(-1)[at]
    mean = np.bincount(which, shade, count) / np.maximum(np.bincount(which, None, count), 1)
    out = wide.copy()
    out.reshape(-1)[at] = np.minimum(np.maximum(shade, 2.0 * mean[which]), 1.0)
    return out
