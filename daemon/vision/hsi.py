"""RGB to hue, saturation, intensity: the Gonzalez-Woods geometric HSI, all planes 8-bit.

Convention (the seed papers say only "hue, saturation, intensity"):

* I = (R + G + B) / 3, rounded, 0..255.
* S = 1 - min(R, G, B) / I, scaled to 0..255; S = 0 for black.
* H = the angle of the colour in the chromaticity plane,
  atan2(sqrt(3) (G - B), 2R - G - B), which is exactly the textbook
  arccos formula; 0..360 degrees mapped to 0..255 (256 codes per turn). Grey
  pixels (max = min) get H = 0, as 2004-era code did.

Speed: the geometric hue is a fixed monotone function of OpenCV's hexcone hue. Within the
sector where R >= G >= B, with t = (G - B) / (R - B), the hexcone hue is 60 t degrees and
the geometric hue is f(t) = atan2(sqrt(3) t, 2 - t); the other five sectors are rotations
and mirror images of this one. So one 256-entry lookup table applied to
``cv2.COLOR_BGR2HSV_FULL``'s hue gives the geometric hue to within one code, at the cost of a
SIMD colour conversion instead of per-pixel trigonometry.
"""

from __future__ import annotations

from typing import NamedTuple

import cv2
import numpy as np

from .cooccurrence import BAND_PIXELS

__all__ = ["HSIPlanes", "colour_contrast", "hue_histogram_rotation", "rgb_to_hsi"]


def _hexcone_to_geometric_lut() -> np.ndarray:
    code = np.arange(256, dtype=np.float64)
    h = code * 360.0 / 256.0
    sector = np.floor(h / 60.0)
    t = h / 60.0 - sector
    even = sector % 2 == 0
    frac = np.where(even, t, 1.0 - t)
    f = np.degrees(np.arctan2(np.sqrt(3.0) * frac, 2.0 - frac))
    theta = np.where(even, 60.0 * sector + f, 60.0 * (sector + 1) - f)
    return (np.rint(theta * 256.0 / 360.0).astype(np.int64) % 256).astype(np.uint8)


_HUE_LUT = _hexcone_to_geometric_lut()


class HSIPlanes(NamedTuple):
    """The three 8-bit planes of an image, each of shape (M, N), and the thresholds that say
    where hue is defined."""

    h: np.ndarray
    s: np.ndarray
    i: np.ndarray
    grey_saturation: int = 5
    min_intensity: int = 0

    @property
    def planes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return (self.h, self.s, self.i)

    @property
    def hue_defined(self) -> np.ndarray:
        """bool (M, N), made anew on each call (not held beside the planes): False where S
        is below ``grey_saturation`` or I below ``min_intensity`` (hue is noise there)."""
        defined = self.s >= self.grey_saturation
        if self.min_intensity > 0:
            defined &= self.i >= self.min_intensity
        return defined


def rgb_to_hsi(bgr: np.ndarray, grey_saturation: int = 5, min_intensity: int = 0) -> HSIPlanes:
    """Convert an 8-bit colour image to geometric H, S, I planes.

    Parameters
    ----------
    bgr : (M, N, 3) uint8 ndarray
        Colour image in OpenCV's B, G, R channel order.
    grey_saturation : int
        Pixels with S below this value (0..255) are marked hue-undefined.
    min_intensity : int
        Pixels with I below this value are marked hue-undefined too.

    Returns
    -------
    HSIPlanes
        ``h``, ``s``, ``i`` as new (M, N) uint8 arrays, and the bool ``hue_defined`` mask
        made from them on demand.

    Examples
    --------
    >>> px = np.array([[[0, 0, 255], [0, 255, 0], [255, 0, 0], [90, 90, 90]]], np.uint8)
    >>> hsi = rgb_to_hsi(px)        # red, green, blue, grey (B, G, R order)
    >>> hsi.h.tolist(), hsi.s.tolist(), hsi.i.tolist()
    ([[0, 85, 171, 0]], [[255, 255, 255, 0]], [[85, 85, 85, 90]])
    >>> hsi.hue_defined.tolist()
    [[True, True, True, False]]
    """
    if bgr.ndim != 3 or bgr.shape[2] != 3:
        raise ValueError(f"expected an (M, N, 3) image, got shape {bgr.shape}")
    if bgr.dtype != np.uint8:
        raise ValueError(f"expected uint8, got {bgr.dtype}")
    rows, cols = bgr.shape[:2]
    h, s, i = (np.empty((rows, cols), np.uint8) for _ in range(3))
    # Every step is per pixel, so a band of rows at a time gives the whole image's planes with
    # a band's temporaries (13 bytes per pixel at once), not the image's.
    step = max(1, BAND_PIXELS // max(cols, 1))
    for r0 in range(0, rows, step):
        band = np.s_[r0 : r0 + step]
        _band_to_hsi(bgr[band], h[band], s[band], i[band])
    return HSIPlanes(h, s, i, grey_saturation, min_intensity)


def _band_to_hsi(bgr: np.ndarray, h: np.ndarray, s: np.ndarray, i: np.ndarray) -> None:
    """Write the H, S, I of a band of rows into ``h``, ``s``, ``i`` (views of the planes)."""
    hexcone = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV_FULL)
    h[:] = cv2.LUT(cv2.extractChannel(hexcone, 0), _HUE_LUT)
    b, g, r = cv2.split(bgr)
    total = b.astype(np.uint16)
    total += g
    total += r
    i[:] = cv2.convertScaleAbs(total, alpha=1.0 / 3.0)
    lowest = cv2.min(cv2.min(b, g), r).astype(np.uint16)
    # S = 255 (sum - 3 min) / sum; OpenCV's x / 0 = 0 gives black S = 0 for free.
    excess = total - 3 * lowest
    s[:] = cv2.divide(excess, total, scale=255.0)


def hue_histogram_rotation(hue: np.ndarray, mask: np.ndarray | None = None) -> int:
    """Return the hue offset that moves the 0/255 cut to the emptiest hue code.

    Red rocks straddle hue 0; without rotation one red unit splits into two classes at the
    two ends of the scale. Adding the returned offset (mod 256) puts the least populated hue
    (circularly smoothed over 16 codes) at code 0.

    Parameters
    ----------
    hue : (M, N) uint8 ndarray
    mask : (M, N) bool ndarray, optional
        Only these pixels count (e.g. where hue is defined).

    Returns
    -------
    int
        Offset in 0..255.

    Examples
    --------
    >>> hue = np.array([[250, 252, 2, 5, 128]], np.uint8)
    >>> off = hue_histogram_rotation(hue)
    >>> rotated = ((hue.astype(int) + off) % 256).ravel().tolist()
    >>> max(rotated[:4]) - min(rotated[:4])    # the red pixels are now contiguous
    11
    """
    if hue.ndim != 2:
        raise ValueError(f"expected an (M, N) plane, got shape {hue.shape}")
    # A few hundred thousand pixels locate the emptiest 16-code window: use every step-th row.
    step = max(1, hue.size >> 18)
    m = None if mask is None else mask[::step].view(np.uint8)
    hist = cv2.calcHist([hue[::step]], [0], m, [256], [0, 256]).ravel()
    kernel = np.ones(16) / 16.0
    wrapped = np.concatenate([hist[-8:], hist, hist[:7]])
    smooth = np.convolve(wrapped, kernel, mode="valid")
    emptiest = int(np.argmin(smooth))
    return (256 - emptiest) % 256


def colour_contrast(saturation: np.ndarray, mask: np.ndarray | None = None) -> int:
    """How far the most saturated 1 % of the view stands above its typical saturation: S's
    99th percentile minus its median (8-bit codes), over ``mask`` if given. A grey road or
    tile reads a few codes, pale Mars rock tens, green plants on soil a hundred.

    >>> s = np.full((10, 10), 20, np.uint8)
    >>> s[0, :2] = 200                                  # 2 % of strongly coloured pixels
    >>> colour_contrast(s)
    180
    """
    m = None if mask is None else mask.view(np.uint8)
    hist = cv2.calcHist([saturation], [0], m, [256], [0, 256]).ravel()
    cum = np.cumsum(hist)
    if cum[-1] == 0:
        return 0
    median, top = np.searchsorted(cum, (0.5 * cum[-1], 0.99 * cum[-1]))
    return int(top - median)
