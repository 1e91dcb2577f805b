"""Refined pointing for chips: register a chip to its station's mosaic, correct the head.

A head lands a few tenths of a degree off where it is sent (gears, mount, backlash), tens of
pixels in a full-resolution chip. As AEGIS does before it fires, the chip is registered to
the image the target was picked on: the station's mosaic is warped to the view the chip
should show from the pose the head reports (through the geometry's ``to_mosaic``, butted or
spherical), the chip is reduced to twice the mosaic's scale, and the shift between them
(phase correlation for the peak, then ECC for the sub-pixel) says where the chip's centre
truly looks. The measurement is relative to what the science saw, so a mosaic tile's own
placement error does not count against the chip; in a butted mosaic only the target's own
tile is used, its neighbours being off by their own errors. Each measurement states its
uncertainty (the window's halves registered alone) for the record.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..pointing.geometry import (
    CameraModel,
    MosaicGeometry,
    SphericalMosaic,
    pixel_centre,
    pixel_index,
    pixel_to_angles,
)

__all__ = [
    "CORRECTION_THRESHOLD",
    "MIN_CONFIDENCE",
    "TAKE_UP",
    "WINDOW",
    "Centring",
    "View",
    "approach",
    "expect",
    "measure",
    "separation",
]

_LOGGER = logging.getLogger(__name__)

CORRECTION_THRESHOLD = 0.05
"""Degrees: a chip measured further than this from its target is corrected once and retaken.
One step of a PTU-46 (D46-17: 185.14 arc-seconds, 0.051 deg); a finer correction could not
be commanded."""
MIN_CONFIDENCE = 0.1
"""Phase-correlation peak (0..1) below which a measurement is not trusted and the head is
left alone: textureless rock or sky, a view the mosaic does not hold."""
MAX_OFFSET = 2.0
"""Degrees: a measured offset beyond this is a false match, not a pointing error."""
TAKE_UP = 0.5
"""Degrees a correction backs off by when it would reverse an axis, so the head arrives from
the side it came from and the backlash taken up on the way in stays taken up."""

WINDOW = 8.0
"""Degrees: the side of the square about the chip's centre that is registered; in a butted
mosaic only the part from the target's own tile counts (:func:`_expected_view`)."""
UPSAMPLE = 2.0
"""How much finer than the mosaic the chip is registered: the chip reduced only half way
and the mosaic interpolated up to meet it. The mosaic holds no finer detail, but the chip's
does not alias away, and ECC finds the shift to a finer fraction of the mosaic's pixel
(chips shot at known offsets over seeded butted mosaics: median measurement error 0.011 ->
0.007 deg, p95 0.042 -> 0.017)."""
_MIN_VALID = 0.2
"""Share of the window the mosaic must hold (of the target's tile, when butted) to measure."""

_GRID = 8
"""Reduced-chip pixels between the points whose place in the mosaic is computed exactly; the
rest are interpolated."""
_MIN_HALF = 16
"""Mosaic pixels: the least half side registered, whatever the mosaic's scale."""
_HIGH_PASS = 5.0
"""Sigma (mosaic pixels) of the blur subtracted before registering: what lighting,
vignetting and exposure change is smooth; what places the chip is not."""
_ECC = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-4)


@dataclass(frozen=True)
class Centring:
    """Where a chip's centre looks, measured on the mosaic, against its target."""

    centre: tuple[float, float]
    """(pan, tilt) degrees the chip's centre shows, in the mosaic's frame."""
    target: tuple[float, float]
    confidence: float
    """The phase-correlation peak, 0..1."""
    uncertainty: float = 0.0
    """Degrees: half the distance between the centres the window's halves (left and right,
    top and bottom) give on their own, the larger pair's: recorded with the chip, how far
    to trust its measured error (about as large as the true measurement error, median 1.0
    to 1.5 times it)."""

    @property
    def offset(self) -> tuple[float, float]:
        """(pan, tilt) degrees to add to the head's pose to centre the target."""
        return self.target[0] - self.centre[0], self.target[1] - self.centre[1]

    @property
    def error(self) -> float:
        """Angle between where the chip's centre looks and the target, degrees."""
        return separation(self.centre, self.target)

    @property
    def trusted(self) -> bool:
        return self.confidence >= MIN_CONFIDENCE and self.error <= MAX_OFFSET

    @property
    def needs_correction(self) -> bool:
        """Trusted and off by more than the threshold. Not discounted by the uncertainty:
        a chip measured just beyond a step usually is (``bench.chips`` with the head's errors
        off: a butted tile sits in its slot while its head stopped on the nearest step, so
        chips are truly up to 0.058 deg off, and such corrections bring them within 0.048;
        waiting for the margin left 0.058 and 0.064 deg chips uncorrected)."""
        return self.trusted and self.error > CORRECTION_THRESHOLD


@dataclass(frozen=True)
class View:
    """What a chip shot at ``pose`` should show about its middle: the mosaic warped to that
    view. It needs no chip, so a survey makes it while the head is still on its way."""

    pose: tuple[float, float]
    target: tuple[float, float]
    size: tuple[int, int]
    """(width, height) of the full-resolution chip it is for."""
    small: CameraModel
    """The chip's camera reduced to where it is registered."""
    corner: tuple[int, int]
    """(x, y) of the registered square in the reduced chip."""
    expected: np.ndarray
    valid: np.ndarray
    sigma: float
    """Of the high pass, in reduced-chip pixels."""

    def measure(self, chip: np.ndarray) -> Centring:
        """Where the middle of ``chip`` (shot at :attr:`pose`, :attr:`size`) looks."""
        small, (x0, y0), side = self.small, self.corner, self.expected.shape[0]
        reduced = cv2.resize(chip, (small.width, small.height), interpolation=cv2.INTER_AREA)
        middle = reduced[y0 : y0 + side, x0 : x0 + side]
        shift, spread, confidence = _register(middle, self.expected, self.valid, self.sigma)
        centre = pixel_to_angles(
            small.width / 2.0 + shift[0], small.height / 2.0 + shift[1], *self.pose, small
        )
        found = Centring(
            (float(centre[0]), float(centre[1])),
            self.target,
            confidence,
            spread * small.degrees_per_pixel,
        )
        _LOGGER.debug(
            "chip at %.3f, %.3f: off by %.3f +- %.3f deg (peak %.2f)",
            *self.pose,
            found.error,
            found.uncertainty,
            confidence,
        )
        return found


def expect(
    pose: tuple[float, float],
    target: tuple[float, float],
    size: tuple[int, int],
    mosaic: np.ndarray,
    geometry: MosaicGeometry,
) -> View | None:
    """The :class:`View` a chip of ``size`` (width, height) shot at the reported ``pose``
    is registered to, for ``target`` (pan, tilt degrees); None when the mosaic holds too
    little of it to tell."""
    scale = _mosaic_scale(geometry, target)
    if scale is None:
        return None
    up = min(UPSAMPLE, scale)
    small = CameraModel(*size, geometry.camera.hfov).scaled(scale / up)
    half = round(WINDOW / 2.0 / small.degrees_per_pixel)
    half = min(max(half, round(_MIN_HALF * up)), small.width // 2, small.height // 2)
    x0, y0 = small.width // 2 - half, small.height // 2 - half
    expected, valid = _expected_view(
        mosaic, geometry, pose, small, (x0, y0, 2 * half), target=target
    )
    if valid.mean() < _MIN_VALID:
        return None
    return View(pose, target, size, small, (x0, y0), expected, valid, _HIGH_PASS * up)


def measure(
    chip: np.ndarray,
    pose: tuple[float, float],
    target: tuple[float, float],
    mosaic: np.ndarray,
    geometry: MosaicGeometry,
) -> Centring | None:
    """Register the middle of ``chip`` (a full-resolution frame shot at the reported
    ``pose``) to ``mosaic`` and say where its centre looks relative to ``target`` (pan, tilt
    degrees); None when the mosaic holds too little of that view to tell."""
    height, width = chip.shape[:2]
    view = expect(pose, target, (width, height), mosaic, geometry)
    return None if view is None else view.measure(chip)


def approach(
    pose: tuple[float, float], came_from: tuple[float, float], goal: tuple[float, float]
) -> list[tuple[float, float]]:
    """The poses to visit from ``pose`` to ``goal`` so each axis arrives moving the way it
    did from ``came_from``: a reversing axis backs off :data:`TAKE_UP` past the goal first.

    >>> approach((10.0, 5.0), (0.0, 0.0), (10.2, 4.9))   # tilt would reverse
    [(10.2, 4.4), (10.2, 4.9)]
    >>> approach((10.0, 5.0), (0.0, 0.0), (10.2, 5.1))
    [(10.2, 5.1)]
    """
    via = []
    for here, before, there in zip(pose, came_from, goal, strict=True):
        came = math.copysign(1.0, here - before) if here != before else 0.0
        reverses = came * (there - here) < 0.0
        via.append(round(there - came * TAKE_UP, 6) if reverses else there)
    first = (via[0], via[1])
    return [first, goal] if first != goal else [goal]


def separation(a: tuple[float, float], b: tuple[float, float]) -> float:
    """Angle between two (pan, tilt) directions, degrees.

    >>> round(separation((10.0, 60.0), (10.2, 60.0)), 4)   # a pan step shrinks up high
    0.1
    """
    u, v = (_unit(*direction) for direction in (a, b))
    return math.degrees(math.atan2(float(np.linalg.norm(np.cross(u, v))), float(u @ v)))


def _unit(pan: float, tilt: float) -> np.ndarray:
    p, t = math.radians(pan), math.radians(tilt)
    return np.array([math.cos(t) * math.sin(p), math.sin(t), math.cos(t) * math.cos(p)])


def _mosaic_scale(geometry: MosaicGeometry, target: tuple[float, float]) -> float | None:
    """How many full-resolution chip pixels make one mosaic pixel around ``target``."""
    step = 0.5
    here = geometry.to_mosaic(*target)
    there = geometry.to_mosaic(target[0] + step, target[1])
    if here is None or there is None:
        there = geometry.to_mosaic(target[0] - step, target[1])
    if here is None or there is None:
        return None
    mosaic_per_degree = math.hypot(there[0] - here[0], there[1] - here[1]) / step
    chip_per_degree = geometry.camera.focal * math.pi / 180.0
    return max(chip_per_degree / mosaic_per_degree, 1.0)


def _expected_view(
    mosaic: np.ndarray,
    geometry: MosaicGeometry,
    pose: tuple[float, float],
    small: CameraModel,
    box: tuple[int, int, int],
    *,
    target: tuple[float, float],
) -> tuple[np.ndarray, np.ndarray]:
    """The mosaic warped to what a camera ``small`` at ``pose`` shows in the square ``box``
    (x0, y0, side; pixel indices), and where it holds data: exact mosaic places on a grid,
    bilinear between them. In a butted mosaic only the tile holding ``target`` counts: its
    neighbours are off by their own pointing errors, and where a seam crosses the window a
    measurement over both lands between them (p95 measurement error 0.15 -> 0.04 deg)."""
    x0, y0, side = box
    n = math.ceil((side - 1) / _GRID) + 1
    along = np.linspace(pixel_centre(0.0), pixel_centre(side - 1.0), n)
    pans, tilts = pixel_to_angles(x0 + along[None, :], y0 + along[:, None], *pose, small)
    grid = np.zeros((3, n, n), np.float32)  # mosaic x, mosaic y, seen
    for i in range(n):
        for j in range(n):
            place = geometry.to_mosaic(float(pans[i, j]), float(tilts[i, j]))
            if place is not None:
                grid[:, i, j] = (*place, 1.0)
    g = np.arange(side, dtype=np.float32) * (n - 1) / max(side - 1, 1)
    gx, gy = np.meshgrid(g, g)
    mx, my, seen = (cv2.remap(layer, gx, gy, cv2.INTER_LINEAR) for layer in grid)
    expected = cv2.remap(
        mosaic, pixel_index(mx), pixel_index(my), cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT
    )
    valid = (seen > 0.999) & (expected.max(axis=2) > 0)
    anchor = geometry.to_mosaic(*target)
    if anchor is not None and not isinstance(geometry, SphericalMosaic):
        tw, th = geometry.tile_size
        valid &= (mx // tw == anchor[0] // tw) & (my // th == anchor[1] // th)
    valid = cv2.erode(valid.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    return expected, valid


def _prepared(image: np.ndarray, valid: np.ndarray, sigma: float) -> np.ndarray:
    """Grey, high-passed (Gaussian ``sigma``) and normalised over ``valid``, zero elsewhere."""
    weight = valid.astype(np.float32)
    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY).astype(np.float32) * weight
    # The local mean over valid pixels only: an edge of the data is no feature of the view.
    mean = cv2.GaussianBlur(grey, (0, 0), sigma) / np.maximum(
        cv2.GaussianBlur(weight, (0, 0), sigma), 1e-3
    )
    detail = (grey - mean) * weight
    spread = float(detail[valid].std()) or 1.0
    return detail / spread


def _register(
    reduced: np.ndarray, expected: np.ndarray, valid: np.ndarray, sigma: float
) -> tuple[tuple[float, float], float, float]:
    """Shift (x, y) with ``reduced(p) ≈ expected(p + shift)``, its uncertainty (pixels:
    half the larger disagreement of the window's opposite halves, each registered alone
    from the whole's shift) and the phase-correlation peak. ECC refines the peak to a
    fraction of a pixel where it converges."""
    a, b = _prepared(reduced, valid, sigma), _prepared(expected, valid, sigma)
    window = cv2.createHanningWindow(a.shape[::-1], cv2.CV_32F)
    (dx, dy), peak = cv2.phaseCorrelate(a, b, window)
    confidence = min(max(peak, 0.0), 1.0) if math.isfinite(peak) else 0.0
    warp = np.array([[1.0, 0.0, dx], [0.0, 1.0, dy]], np.float32)
    mask = valid.astype(np.uint8)
    try:
        _, warp = cv2.findTransformECC(a, b, warp, cv2.MOTION_TRANSLATION, _ECC, mask, 3)
    except cv2.error:  # did not converge: the peak's own sub-pixel estimate stands
        _LOGGER.debug("ECC did not converge; phase correlation's shift kept")
    side_y, side_x = (n // 2 for n in mask.shape)
    spread = 0.0
    for cut in (np.s_[:, :side_x], np.s_[:side_y, :]):  # left | right, top | bottom
        halves = []
        for part in (cut, tuple(_rest(c) for c in cut)):
            alone = np.zeros_like(mask)
            alone[part] = mask[part]
            try:
                _, moved = cv2.findTransformECC(
                    a, b, warp.copy(), cv2.MOTION_TRANSLATION, _ECC, alone, 3
                )
            except cv2.error:  # a half that cannot be registered says nothing either way
                continue
            halves.append(moved[:, 2])
        if len(halves) == 2:
            spread = max(spread, float(np.hypot(*(halves[0] - halves[1]))) / 2.0)
    return (float(warp[0, 2]), float(warp[1, 2])), spread, confidence


def _rest(part: slice) -> slice:
    """The other side of a half-open slice of an axis (all of it for the whole axis)."""
    if part.stop is None:
        return part
    return slice(part.stop, None)
