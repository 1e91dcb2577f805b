"""A registered mosaic: overlapping frames projected onto one spherical canvas from the
poses the head recorded, each pose refined on the frames placed before it, the lens's
vignetting measured on the overlaps and divided out, gains compensated and seams blended
(OpenCV's ``detail`` module, as its stitching pipeline uses it); once the science has
looked, the seams can be cut again off what it found, so that is drawn from one frame.

Registration is seeded by the pose and only ever corrects it: a frame is moved by the ECC
translation that best aligns it with its already placed neighbours on their overlap, and
only when the alignment is confident (correlation, texture in both directions) and the
correction is one the head could plausibly have made. Otherwise (textureless rock, sky, no
overlap) the frame stays where the head says, and says so. Pixels no frame covers are
no-data: exactly black, and only they are (:func:`uncovered` reads them back exactly, where
the science's own rule, ``vision.nodata``, leaves out specks under its size floor).

Pure imaging: frames and poses in, a mosaic and per-tile records out.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from ..pointing.geometry import MosaicGeometry, SphericalMosaic, pixel_index

__all__ = [
    "KEEP_OFF_PX",
    "KEEP_OFF_ROUNDS",
    "Stitcher",
    "TileFit",
    "no_data",
    "rotation",
    "uncovered",
]

_LOGGER = logging.getLogger(__name__)

MAX_CORRECTION_DEG = 2.0
"""Largest correction accepted: what two poses, each a few tenths of a degree off on each
axis (0.3° rms plus backlash on the emulated PTU-46), can disagree by, with room to spare;
beyond it a match is more likely a repeated pattern than the head's error."""
MIN_CONFIDENCE = 0.5
"""Lowest ECC correlation coefficient (of the overlaps' texture, shading removed) of an
accepted registration: the simulated cliff's rock under a flawed camera correlates at 0.8
to 0.95 once aligned, and a first try several pixels off can land at 0.5 on the way there;
frames that show different things stay near 0."""
MIN_TEXTURE = 0.6
"""Lowest RMS grey-level gradient (per mosaic pixel) in the overlap's weakest direction: below
it a shift along that direction is not measured but guessed (sky, smooth rock, a gradient).
Sensor noise of 2 grey levels gives 0.2 once reduced 4 times; the simulated cliff's finest
rock 1.2 and more."""
_MIN_OVERLAP = 200
"""Fewest overlapping pixels worth registering on."""
_ITERATIONS = 2
"""Register, re-project, register again: a tilt correction is a vertical shift on the
canvas only to first order."""
_SHADE = 6.0
"""Sigma (mosaic pixels) of the shading taken off before registering: wider than rock
grain, narrower than a frame's vignetting."""
_SEAM_SHADE = 3.0
"""Sigma (mosaic pixels) of the shading taken off the frames before finding seams."""
_SEAM_EDGE = 4.0
"""Weight of a frame's edges (grey levels per pixel) in the seam's cost."""
_SEAM_REACH = 6.0
"""Sigma (mosaic pixels) over which an edge makes a seam costly: a small feature's whole
body, not only its outline."""
_FLAT_SHADE = 2.0
"""Sigma (mosaic pixels) of the smoothing of the levels the vignetting is measured on: sensor
noise and the residual misregistration of fine grain averaged out, the lens's falloff kept."""
_FLAT_MIN_PIXELS = 500
"""Fewest overlap pixels (all pairs) worth measuring a vignetting on."""
_FLAT_FLOOR = 0.5
"""Darkest corner a measured vignetting may have; a fit darker than that is rejected (a
cliff's shading rather than the lens's)."""
_FLAT_CEILING = 1.02
"""Brightest a measured falloff may make any part of a frame relative to its centre: a lens
does not brighten its corners, a fit does only by noise or the cliff's shading."""
KEEP_OFF_PX = 8.0
"""Clearance (mosaic pixels) :meth:`Stitcher.keep_off` keeps seams from a point: past
``bench.mosaic``'s 3 px seam band (up to 3√2 px away, it is square) by the reach of the
blend, which mixes two frames' detail up to ~5 px either side of a seam (its bands on the
2x- and 4x-reduced masks; the finest is cut sharp, the 8x one is shading, not detail); and
room for the point to move a few pixels when the mosaic is composed again."""
KEEP_OFF_ROUNDS = 2
"""Most times a survey re-cuts the seams off its top points (:meth:`Stitcher.keep_off`) and
analyses the mosaic again: the recomposed mosaic's points are mostly the first ones, kept
off; a second round keeps off those that moved or replaced them."""
_ECC = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 60, 1e-4)
_LEAST = 1
"""Level a covered pixel blended to pure black is lifted to (every channel): one grey level
of crushed shadow, so exact black marks no-data alone."""


def uncovered(mosaic: np.ndarray) -> np.ndarray:
    """The pixels of a composed mosaic (:meth:`Stitcher.compose`, or its lossless PNG) no
    frame covers: exactly black, which no covered pixel is. (M, N) bool.

    >>> m = np.full((2, 3, 3), 90, np.uint8)
    >>> m[0, 0] = 0
    >>> uncovered(m).astype(int).tolist()
    [[1, 0, 0], [0, 0, 0]]
    """
    return ~mosaic.any(axis=2)


def no_data(mosaic: np.ndarray, geometry: MosaicGeometry | None) -> np.ndarray | None:
    """Where a station's ``mosaic``, shot as ``geometry``, shows nothing: a stitched one's
    uncovered pixels; None for a butted one (its black may be a shadow the camera crushed)."""
    return uncovered(mosaic) if isinstance(geometry, SphericalMosaic) else None


def rotation(pan: float, tilt: float) -> np.ndarray:
    """The camera-to-world rotation of a head at (pan, tilt) degrees, in OpenCV's axes (x
    right, y down, z forward), as ``pointing.geometry.pixel_to_angles`` turns rays.

    >>> np.round(rotation(90.0, 0.0) @ [0.0, 0.0, 1.0], 6).tolist()  # looking right
    [1.0, 0.0, 0.0]
    """
    p, t = math.radians(pan), math.radians(tilt)
    cp, sp, ct, st = math.cos(p), math.sin(p), math.cos(t), math.sin(t)
    return np.array([[cp, st * sp, ct * sp], [0.0, ct, -st], [-sp, st * cp, ct * cp]], np.float32)


@dataclass(frozen=True)
class TileFit:
    """How one tile was placed: the recorded pose, the correction registration made (mosaic
    pixels and degrees; zero when it fell back to the pose), and why."""

    row: int
    col: int
    pose: tuple[float, float]
    shift_px: tuple[float, float] = (0.0, 0.0)
    correction_deg: tuple[float, float] = (0.0, 0.0)
    confidence: float = 0.0
    registered: bool = False
    note: str = ""

    @property
    def placed(self) -> tuple[float, float]:
        """The pose the tile is projected from."""
        return self.pose[0] + self.correction_deg[0], self.pose[1] + self.correction_deg[1]

    def record(self) -> dict[str, Any]:
        """The manifest's ``registration`` of the tile."""
        return {
            "registered": self.registered,
            "dx_px": round(self.shift_px[0], 3),
            "dy_px": round(self.shift_px[1], 3),
            "dpan_deg": round(self.correction_deg[0], 5),
            "dtilt_deg": round(self.correction_deg[1], 5),
            "confidence": round(self.confidence, 4),
            "note": self.note,
        }


@dataclass
class _Warped:
    corner: tuple[int, int]
    """Top-left in mosaic pixels."""
    image: np.ndarray
    mask: np.ndarray


class Stitcher:
    """Places frames one at a time (:meth:`add`: registered on those placed before, warped,
    and its seams with them cut, while the head moves to the next), then composes the mosaic
    (:meth:`compose`: gains and blending, which need every frame); :meth:`keep_off` cuts
    the seams again off the points the science found, for :meth:`compose` to draw anew."""

    def __init__(
        self,
        geometry: SphericalMosaic,
        max_correction_deg: float = MAX_CORRECTION_DEG,
        min_confidence: float = MIN_CONFIDENCE,
        *,
        register: bool = True,
        flatten: bool = True,
    ) -> None:
        """``register`` false places every frame by its pose alone; ``flatten`` false
        composes the frames as shot, their vignetting left in."""
        self.geometry = geometry
        self.register = register
        self.flatten = flatten
        self.max_correction_deg = max_correction_deg
        self.min_confidence = min_confidence
        cam, (tw, th) = geometry.camera, geometry.tile_size
        fx, fy = cam.focal * tw / cam.width, cam.focal * th / cam.height
        # Pixel index k's centre is k in OpenCV, k + 0.5 in pointing.geometry.
        self._k = np.array([[fx, 0, tw / 2 - 0.5], [0, fy, th / 2 - 0.5], [0, 0, 1]], np.float32)
        self._warper = cv2.PyRotationWarper("spherical", geometry.scale)
        width, height = geometry.size
        self._reference = np.zeros((height, width), np.float32)
        self._covered = np.zeros((height, width), np.uint8)
        self._shown = np.zeros((height, width, 3), np.float32)
        """The seam cost image (:func:`_seam_cost`) of the tile each pixel shows."""
        self.tiles: list[tuple[np.ndarray, TileFit]] = []
        self._warped: list[_Warped] = []
        self.vignetting: np.ndarray | None = None
        """The lens's falloff :meth:`compose` measured on the overlaps and divided out of
        every frame ((tile rows, cols) float32, 1 at the centre), None if not measured."""
        self.owners = np.full((height, width), -1, np.int16)
        """Which tile (its index in :attr:`tiles`) each mosaic pixel shows (-1: none): the
        seams are where it changes; pixels no frame covers stay -1 once composed."""

    def reduce(self, image: np.ndarray) -> np.ndarray:
        """A frame at the mosaic's scale, as the butted mosaic reduces it."""
        return cv2.resize(image, self.geometry.tile_size, interpolation=cv2.INTER_AREA)

    def _warp(
        self, small: np.ndarray, pose: tuple[float, float], border: int = cv2.BORDER_CONSTANT
    ) -> _Warped:
        """``small`` projected from ``pose``: its corner on the canvas, image (``border``
        beyond the frame) and mask (its own no-data excluded, the bilinear rim eroded)."""
        r = rotation(*pose)
        corner, image = self._warper.warp(small, self._k, r, cv2.INTER_LINEAR, border)
        valid = np.where(small.any(axis=2), 255, 0).astype(np.uint8)
        _, mask = self._warper.warp(valid, self._k, r, cv2.INTER_NEAREST, cv2.BORDER_CONSTANT)
        mask = cv2.erode(mask, np.ones((3, 3), np.uint8))
        u0, v0 = self.geometry.origin
        return _Warped((corner[0] - u0, corner[1] - v0), image, mask)

    def _window(self, w: _Warped) -> tuple[slice, slice, slice, slice] | None:
        """Matching slices (canvas rows, cols, warped rows, cols) of a warped frame's part on
        the canvas; None if it lies wholly outside."""
        height, width = self._covered.shape
        (x, y), (h, wd) = w.corner, w.mask.shape
        x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + wd, width), min(y + h, height)
        if x0 >= x1 or y0 >= y1:
            return None
        return slice(y0, y1), slice(x0, x1), slice(y0 - y, y1 - y), slice(x0 - x, x1 - x)

    def _measure(self, w: _Warped) -> tuple[np.ndarray, float, str]:
        """The ECC shift (dx, dy) aligning ``w`` with the placed frames (pixels, to add to
        its corner), the correlation, and what failed ('' if nothing)."""
        win = self._window(w)
        if win is None:
            return np.zeros(2), 0.0, "outside the mosaic"
        cr, cc, wr, wc = win
        overlap = (w.mask[wr, wc] > 0) & (self._covered[cr, cc] > 0)
        if int(overlap.sum()) < _MIN_OVERLAP:
            return np.zeros(2), 0.0, "no overlap with placed frames"
        ys, xs = np.nonzero(overlap)
        r0, r1, c0, c1 = ys.min(), ys.max() + 1, xs.min(), xs.max() + 1
        band = overlap[r0:r1, c0:c1].astype(np.uint8)
        template = _detail(self._reference[cr, cc][r0:r1, c0:c1], band)
        grey = cv2.cvtColor(w.image, cv2.COLOR_BGR2GRAY)[wr, wc][r0:r1, c0:c1]
        moving = _detail(grey.astype(np.float32), band)
        texture = _weakest_gradient(template, band)
        if texture < MIN_TEXTURE:
            return np.zeros(2), 0.0, f"textureless overlap (gradient {texture:.2f})"
        try:
            rho, warp = _ecc(template, moving, band)
        except cv2.error as exc:
            return np.zeros(2), 0.0, f"ECC failed ({str(exc).strip().splitlines()[-1]})"
        # ECC finds moving(x + p) = template(x): the frame shows its content p too far on.
        return -warp[:, 2].astype(np.float64), float(rho), ""

    def add(self, row: int, col: int, image: np.ndarray, pose: tuple[float, float]) -> TileFit:
        """Place a frame shot at the recorded ``pose`` (degrees), registered on the frames
        placed before it; its fit."""
        small = self.reduce(image)
        if not self.tiles:
            fit = TileFit(row, col, pose, note="the first tile anchors the mosaic")
        elif self.register:
            fit = self._register(row, col, small, pose)
        else:
            fit = TileFit(row, col, pose, note="placed by its pose")
        warped = self._warp(small, fit.placed)
        self._paste(warped)
        self.tiles.append((small, fit))
        self._warped.append(warped)
        self._cut(len(self.tiles) - 1)
        return fit

    def _register(
        self, row: int, col: int, small: np.ndarray, pose: tuple[float, float]
    ) -> TileFit:
        """The fit of a frame registered on the placed frames, or kept at its pose."""
        per_deg = math.radians(1.0) * self.geometry.scale  # mosaic pixels per degree
        shift, rho = np.zeros(2), 0.0
        for _ in range(_ITERATIONS):
            placed = (pose[0] + shift[0] / per_deg, pose[1] - shift[1] / per_deg)
            step, measured, failed = self._measure(self._warp(small, placed))
            total = shift + step
            if not failed and measured < self.min_confidence:
                failed = f"low confidence ({measured:.2f})"
            if not failed and float(np.hypot(*total)) > self.max_correction_deg * per_deg:
                failed = (
                    f"correction of {np.hypot(*total) / per_deg:.2f}° is over "
                    f"{self.max_correction_deg:g}°"
                )
            if failed and rho:  # the last accepted step stands
                break
            if failed:
                _LOGGER.info("tile (%d, %d) kept at its pose: %s", row, col, failed)
                return TileFit(row, col, pose, confidence=measured, note=failed)
            shift, rho = total, measured
        degrees = (float(shift[0]) / per_deg, -float(shift[1]) / per_deg)
        return TileFit(row, col, pose, (float(shift[0]), float(shift[1])), degrees, rho, True)

    def _paste(self, w: _Warped) -> None:
        """Add a placed frame to the reference later frames register on (first come, kept)."""
        win = self._window(w)
        if win is None:
            return
        cr, cc, wr, wc = win
        fresh = (w.mask[wr, wc] > 0) & (self._covered[cr, cc] == 0)
        grey = cv2.cvtColor(w.image, cv2.COLOR_BGR2GRAY)[wr, wc].astype(np.float32)
        self._reference[cr, cc][fresh] = grey[fresh]
        self._covered[cr, cc][fresh] = 255

    def _cut(self, k: int, kept: np.ndarray | None = None) -> None:
        """Give tile ``k`` the pixels on its side of the graph-cut seam with the tiles shown
        so far (all it covers where none is): :attr:`owners`. Where ``kept`` (canvas, a
        tile index or -1) names a tile, only that tile may show the pixel: it takes it from
        the tiles shown, and any other leaves it to them, so the seams pass around."""
        w, fit = self._warped[k], self.tiles[k][1]
        win = self._window(w)
        if win is None:
            return
        cr, cc, wr, wc = win
        cost = _seam_cost(w.image, (-1.0) ** (fit.row + fit.col))[wr, wc]
        mask = np.where(w.mask[wr, wc] > 0, 255, 0).astype(np.uint8)
        shown = np.where(self.owners >= 0, 255, 0).astype(np.uint8)
        if kept is not None:
            mask[(kept[cr, cc] >= 0) & (kept[cr, cc] != k)] = 0
            shown[kept == k] = 0
        if shown[cr, cc][mask > 0].any():
            _, cut = cv2.detail_GraphCutSeamFinder("COST_COLOR").find(
                [self._shown, cost],
                [(0, 0), (cc.start, cr.start)],
                [cv2.UMat(shown), cv2.UMat(mask)],
            )
            mask = cut.get()
        mine = mask > 0
        self.owners[cr, cc][mine] = k
        self._shown[cr, cc][mine] = cost[mine]

    def keep_off(self, points: Sequence[tuple[float, float]], radius: float = KEEP_OFF_PX) -> bool:
        """Whether a seam of :attr:`owners` passes within ``radius`` mosaic pixels of one of
        ``points`` ((x, y) canvas pixel indices, as the science gives them, the first most
        worth keeping); if one does, every seam is cut again, in the order the tiles came,
        each point's surroundings given whole to one frame that shows them all (the one
        showing the point now if it can), as a panorama editor's masks keep a subject in
        one frame: the graph cut routes the seams around them. :meth:`compose` then gives
        the new mosaic and owners. Where no frame shows all of a point's surroundings (a
        rim against the no-data, a corner three frames barely share) or an earlier point
        took some, the frame covering the most keeps what it can, and the log says so."""
        discs = [self._disc(x, y, radius) for x, y in points]
        if not any(_seamed(self.owners[disc]) for disc in discs):
            return False
        coverage = np.stack([self._coverage(k) for k in range(len(self.tiles))])
        kept = np.full(self.owners.shape, -1, np.int16)
        for (x, y), disc in zip(points, discs, strict=True):
            owner = int(
                self.owners[_clamp(round(y), kept.shape[0]), _clamp(round(x), kept.shape[1])]
            )
            if not _keep(kept, coverage, disc, owner):
                _LOGGER.info(
                    "no frame can show all within %g px of (%.0f, %.0f): a seam may pass there",
                    radius,
                    x,
                    y,
                )
        self.owners.fill(-1)
        self._shown.fill(0.0)
        for k in range(len(self.tiles)):
            self._cut(k, kept)
        return True

    def _disc(self, x: float, y: float, radius: float) -> tuple[np.ndarray, np.ndarray]:
        """The canvas pixels within ``radius`` of (x, y): their (rows, cols) indices."""
        height, width = self.owners.shape
        r0, c0 = max(math.ceil(y - radius), 0), max(math.ceil(x - radius), 0)
        r1 = min(math.floor(y + radius) + 1, height)
        c1 = min(math.floor(x + radius) + 1, width)
        yy, xx = np.mgrid[r0 : max(r1, r0), c0 : max(c1, c0)]
        inside = (xx - x) ** 2 + (yy - y) ** 2 <= radius * radius
        return yy[inside], xx[inside]

    def _coverage(self, k: int) -> np.ndarray:
        """The canvas pixels tile ``k`` covers, (M, N) bool."""
        out = np.zeros(self.owners.shape, bool)
        win = self._window(self._warped[k])
        if win is not None:
            cr, cc, wr, wc = win
            out[cr, cc] = self._warped[k].mask[wr, wc] > 0
        return out

    def compose(self) -> np.ndarray:
        """The mosaic: every frame from its placed pose, flat-fielded (:attr:`vignetting`),
        gains compensated, seams found and blended; black where no frame reaches and
        nowhere else (:func:`uncovered`). Shape ``(height, width, 3)`` uint8.
        :attr:`owners` then says which tile (its index in :attr:`tiles`) each pixel shows,
        -1 for none: the seams are where it changes."""
        width, height = self.geometry.size
        if not self.tiles:
            return np.zeros((height, width, 3), np.uint8)
        if self.flatten:
            self.vignetting = self._measure_vignetting()
        flat = 1.0 if self.vignetting is None else self.vignetting[..., None]
        # Reflected beyond each frame, as OpenCV's stitcher warps: the blend's coarser bands
        # reach past a seam, and a frame's black surround would darken it along the frame's
        # edge, a line the science takes for a feature.
        warped = [
            self._warp(
                np.clip(small / flat + 0.5, 0, 255).astype(np.uint8),
                fit.placed,
                cv2.BORDER_REFLECT,
            )
            for small, fit in self.tiles
        ]
        compensator = cv2.detail.BlocksGainCompensator()
        compensator.feed(
            corners=[w.corner for w in warped],
            images=[w.image for w in warped],
            masks=[w.mask for w in warped],
        )
        blender = cv2.detail_MultiBandBlender(0, 3)
        blender.prepare((0, 0, width, height))
        for k, w in enumerate(warped):
            win = self._window(w)
            if win is None:
                continue
            cr, cc, wr, wc = win
            image = compensator.apply(k, w.corner, w.image.copy(), w.mask)[wr, wc]
            seam_mask = np.where(self.owners[cr, cc] == k, 255, 0).astype(np.uint8)
            blender.feed(image.astype(np.int16), seam_mask, (cc.start, cr.start))
        result, result_mask = blender.blend(None, None)
        mosaic = np.clip(result, 0, 255).astype(np.uint8)
        covered = result_mask > 0
        mosaic[covered & ~mosaic.any(axis=2)] = _LEAST  # black is kept for no-data alone
        mosaic[~covered] = 0
        self.owners[~covered] = -1
        return mosaic

    def correction_at(self, pan: float, tilt: float) -> tuple[float, float]:
        """The registration correction (degrees) of the tile the composed mosaic shows at
        (pan, tilt) in its frame; (0, 0) where none does.

        The canvas's frame is the first tile's, off the world by that tile's pointing error;
        each later tile's correction is how far its own head pose was off from that. A
        head's error is repeatable (gears, mount: ``ptu.emulator_errors``), so a head sent
        to a target less the correction of the tile that shows it lands as that tile did
        (``bench.chips``, registered mosaics: a first chip's error 0.363° → 0.180° median,
        the refined chips' p95 0.059° → 0.044°, the corrections shorter)."""
        at = self.geometry.to_mosaic(pan, tilt)
        if at is None:
            return 0.0, 0.0
        height, width = self.owners.shape
        x, y = (
            min(max(round(pixel_index(v)), 0), n - 1)
            for v, n in zip(at, (width, height), strict=True)
        )
        k = int(self.owners[y, x])
        return (0.0, 0.0) if k < 0 else self.tiles[k][1].correction_deg

    def _measure_vignetting(self) -> np.ndarray | None:
        """The lens's falloff as the overlaps show it, or None: a point of the world seen by
        two frames at different distances from their centres differs in level by their gains
        and by the falloff between those distances, whatever the rock there is. Least
        squares on the log levels of every overlapping pair fits each frame's gain and a
        falloff ``exp(a r^2 + b r^4)`` (r: distance from the centre over the half diagonal),
        the photometric model panorama tools calibrate. Left in, the falloff is a step at
        every seam (a frame's dark edge against its neighbour's bright middle) that gains,
        one per frame or block, cannot take off."""
        (tw, th), n = self.geometry.tile_size, len(self.tiles)
        yy, xx = np.mgrid[0:th, 0:tw].astype(np.float32)
        r2 = ((xx - (tw - 1) / 2) ** 2 + (yy - (th - 1) / 2) ** 2) / (0.25 * (tw * tw + th * th))
        levels, radii = [], []
        for (_, fit), w in zip(self.tiles, self._warped, strict=True):
            grey = cv2.cvtColor(w.image, cv2.COLOR_BGR2GRAY).astype(np.float32)
            grey = cv2.GaussianBlur(grey, (0, 0), _FLAT_SHADE)
            inner = cv2.erode(w.mask, np.ones((7, 7), np.uint8)) > 0
            levels.append(np.where(inner & (grey > 8) & (grey < 250), grey, 0))
            _, warped_r2 = self._warper.warp(
                r2, self._k, rotation(*fit.placed), cv2.INTER_LINEAR, cv2.BORDER_CONSTANT
            )
            radii.append(warped_r2)
        rows, rhs = [], []
        for k in range(n):
            for m in range(k + 1, n):
                a, b = self._warped[k].corner, self._warped[m].corner
                (hk, wk), (hm, wm) = levels[k].shape, levels[m].shape
                x0, y0 = max(a[0], b[0]), max(a[1], b[1])
                x1, y1 = min(a[0] + wk, b[0] + wm), min(a[1] + hk, b[1] + hm)
                if x0 >= x1 or y0 >= y1:
                    continue
                sk = np.s_[y0 - a[1] : y1 - a[1], x0 - a[0] : x1 - a[0]]
                sm = np.s_[y0 - b[1] : y1 - b[1], x0 - b[0] : x1 - b[0]]
                both = (levels[k][sk] > 0) & (levels[m][sm] > 0)
                if not both.any():
                    continue
                rk, rm = radii[k][sk][both], radii[m][sm][both]
                gains = np.zeros((rk.size, n))
                gains[:, k], gains[:, m] = 1.0, -1.0  # the first tile's gain is the unit
                rows.append(np.column_stack([gains[:, 1:], rk - rm, rk * rk - rm * rm]))
                rhs.append(np.log(levels[k][sk][both]) - np.log(levels[m][sm][both]))
        if not rows or sum(len(r) for r in rhs) < _FLAT_MIN_PIXELS:
            return None
        solution, *_ = np.linalg.lstsq(np.concatenate(rows), np.concatenate(rhs), rcond=None)
        a, b = solution[-2:]
        falloff = np.exp(a * r2 + b * r2 * r2).astype(np.float32)
        if float(falloff.min()) < _FLAT_FLOOR or float(falloff.max()) > _FLAT_CEILING:
            _LOGGER.info("vignetting fit rejected (a %.3f, b %.3f): frames composed as shot", a, b)
            return None
        return falloff


def _ecc(template: np.ndarray, moving: np.ndarray, mask: np.ndarray) -> tuple[float, np.ndarray]:
    """The ECC translation (correlation, 2x3 warp) aligning ``moving`` on ``template`` over
    ``mask``, started from no shift and from the phase correlation's, the better kept: a
    head's error of a degree is several mosaic pixels, beyond where ECC alone converges."""
    band = mask > 0
    filled = [np.where(band, img, np.float32(img[band].mean())) for img in (template, moving)]
    window = cv2.createHanningWindow(template.shape[::-1], cv2.CV_32F)
    (dx, dy), _ = cv2.phaseCorrelate(*filled, window)
    best: tuple[float, np.ndarray] | None = None
    failure: cv2.error | None = None
    for seed in ((0.0, 0.0), (dx, dy)):
        warp = np.array([[1, 0, seed[0]], [0, 1, seed[1]]], np.float32)
        try:
            found = cv2.findTransformECC(
                template, moving, warp, cv2.MOTION_TRANSLATION, _ECC, mask, 3
            )
        except cv2.error as exc:
            failure = exc
            continue
        if best is None or found[0] > best[0]:
            best = found
    if best is None:
        raise failure or cv2.error("ECC found nothing")
    return best


def _seam_cost(image: np.ndarray, sign: float) -> np.ndarray:
    """What the seam finder compares (float32): the frame's detail, its shading taken off,
    and its edges' strength added with ``sign`` (+1 or -1, opposite for neighbouring tiles).

    On colour a seam runs where the frames' levels differ least: the dark of a shadow or a
    ledge (a gain's error scales with the level), just where the science looks. On detail
    it runs where the frames agree; the edges' strength, of opposite signs in two
    neighbours, makes cutting through an edge cost what the edge is worth, so the seam
    keeps to plain rock and the science sees no seam along its features."""
    img = image.astype(np.float32)
    detail = img - cv2.GaussianBlur(img, (0, 0), _SEAM_SHADE)
    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    edges = cv2.magnitude(
        cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3), cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3)
    )
    edges = cv2.GaussianBlur(edges, (0, 0), _SEAM_REACH) * (_SEAM_EDGE / 8.0 * sign)
    return detail + edges[..., None]


def _seamed(owners: np.ndarray) -> bool:
    """Whether ``owners`` (tile indices, -1 for none) name more than one tile."""
    return np.unique(owners[owners >= 0]).size > 1


def _clamp(index: int, size: int) -> int:
    """``index`` moved onto ``range(size)``."""
    return min(max(index, 0), size - 1)


def _keep(
    kept: np.ndarray, coverage: np.ndarray, disc: tuple[np.ndarray, np.ndarray], owner: int
) -> bool:
    """Mark the covered pixels of ``disc`` in ``kept`` (canvas, tile index or -1) for the
    one tile to show them: one that covers them all (``coverage``: (tiles, M, N) bool) and
    agrees with what ``kept`` already says there, ``owner`` first; whether one could. Else
    the tile covering the most keeps those pixels of it nothing is kept for yet."""
    shows = coverage[:, disc[0], disc[1]]
    covered = shows.any(axis=0)
    here = kept[disc]
    taken = here >= 0
    counts = shows.sum(axis=1)
    for k in sorted(range(len(shows)), key=lambda k: (k != owner, -counts[k])):
        if shows[k][covered].all() and (here[taken] == k).all():
            kept[disc[0][covered], disc[1][covered]] = k
            return True
    best = int(np.argmax(counts))
    free = shows[best] & ~taken
    kept[disc[0][free], disc[1][free]] = best
    return False


def _detail(grey: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """``grey`` less its local mean over ``mask`` (Gaussian, sigma :data:`_SHADE`): the
    rock's texture without the vignetting and exposure ramps that differ between two frames
    on their overlap (one frame's left edge is the other's right)."""
    m = mask.astype(np.float32)
    num = cv2.GaussianBlur(grey * m, (0, 0), _SHADE)
    den = cv2.GaussianBlur(m, (0, 0), _SHADE)
    return np.where(mask > 0, grey - num / np.maximum(den, 1e-3), 0.0).astype(np.float32)


def _weakest_gradient(grey: np.ndarray, mask: np.ndarray) -> float:
    """RMS gradient (grey levels per pixel) along the overlap's least textured direction:
    the square root of the smaller eigenvalue of the mean structure tensor on ``mask``."""
    gx = cv2.Sobel(grey, cv2.CV_32F, 1, 0, ksize=3) / 8.0
    gy = cv2.Sobel(grey, cv2.CV_32F, 0, 1, ksize=3) / 8.0
    inner = cv2.erode(mask, np.ones((3, 3), np.uint8)) > 0
    if not inner.any():
        return 0.0
    a, b, c = (float(v[inner].mean()) for v in (gx * gx, gx * gy, gy * gy))
    return math.sqrt(max(0.0, (a + c) / 2 - math.hypot((a - c) / 2, b)))
