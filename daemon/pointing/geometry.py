"""Where the camera looks: unit positions, degrees, camera pixels and mosaic pixels.

Conventions: pan is a rotation about the vertical axis, positive to the right; tilt a
rotation about the camera's horizontal axis, positive up; both in degrees. Image pixels
are continuous (x = column, y = row) coordinates with y down: pixel index k spans
[k, k + 1), so its centre is k + 0.5 and the image centre is (width/2, height/2). The
camera is a pinhole on the PTU's rotation centre (the seed's rig: a camcorder close to
both axes, outcrop tens of metres away, so parallax is negligible). The mapping is exact
under those assumptions, not the small-angle "degrees per pixel" approximation, so
re-pointing stays right at the edges of a wide field of view and at steep tilts.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "CameraModel",
    "MosaicGeometry",
    "SphericalMosaic",
    "angles_to_pixel",
    "degrees_to_positions",
    "pixel_centre",
    "pixel_index",
    "pixel_to_angles",
    "positions_to_degrees",
    "view_extent",
]

Span = tuple[float, float]
"""An angular range, (min, max) degrees."""

_SEAM = 1e-6
"""Pixels by which a direction may fall outside a tile and still count as seen in it: one on
the seam between two butted tiles (the centre of a mosaic of two rows, where the next
station is aimed) lands a rounding error outside both, y = 576.0000000000002 in the upper
and -6e-14 in the lower."""


def positions_to_degrees(positions: float, resolution: float) -> float:
    """Unit positions to degrees, with ``resolution`` in arc-seconds per position as ``PR``
    reports it.

    >>> round(positions_to_degrees(3090, 185.1428), 3)
    158.914
    """
    return positions * resolution / 3600.0


def degrees_to_positions(degrees: float, resolution: float) -> int:
    """Degrees to the nearest unit position.

    >>> degrees_to_positions(-46.65, 185.1428)
    -907
    """
    return round(degrees * 3600.0 / resolution)


def pixel_centre(k):
    """The continuous coordinate of pixel index ``k``'s centre: ``k + 0.5`` (scalars and
    arrays alike).

    >>> pixel_centre(0), pixel_centre(719)
    (0.5, 719.5)
    """
    return k + 0.5


def pixel_index(x):
    """The inverse of :func:`pixel_centre`, ``x - 0.5``: continuous ``x`` where a pixel's
    centre is its index, as OpenCV samples (``cv2.remap``) and ``result.json`` gives points.

    >>> pixel_index(pixel_centre(7))
    7.0
    """
    return x - 0.5


@dataclass(frozen=True)
class CameraModel:
    """A pinhole camera: image size in pixels and horizontal field of view in degrees."""

    width: int = 720
    height: int = 576
    hfov: float = 30.0

    @property
    def focal(self) -> float:
        """Focal length in pixels."""
        return (self.width / 2.0) / math.tan(math.radians(self.hfov) / 2.0)

    @property
    def vfov(self) -> float:
        return math.degrees(2.0 * math.atan((self.height / 2.0) / self.focal))

    @property
    def degrees_per_pixel(self) -> float:
        """``hfov / width``: the small-angle approximation, for sizes and spreads only
        (pointing uses the exact mapping)."""
        return self.hfov / self.width

    def scaled(self, factor: float) -> CameraModel:
        """The same optics seen through an image reduced ``factor`` times."""
        return CameraModel(round(self.width / factor), round(self.height / factor), self.hfov)

    def zoomed(self, level: float) -> CameraModel:
        """The same sensor behind a lens ``level`` times longer (a zoom, or walking closer
        to a distant flat cliff).

        >>> round(CameraModel(hfov=30.0).zoomed(5.0).hfov, 3)
        6.135
        """
        half = math.atan(math.tan(math.radians(self.hfov) / 2.0) / level)
        return CameraModel(self.width, self.height, math.degrees(2.0 * half))


def pixel_to_angles(x, y, pan: float, tilt: float, camera: CameraModel):
    """World (pan, tilt) in degrees of the ray through pixel (x, y) of a camera at (pan, tilt).

    Works on scalars and arrays alike.

    >>> cam = CameraModel(720, 576, 30.0)
    >>> [round(float(v), 6) for v in pixel_to_angles(360, 288, 12.0, -3.0, cam)]
    [12.0, -3.0]
    >>> [round(float(v), 3) for v in pixel_to_angles(720, 288, 0.0, 0.0, cam)]
    [15.0, 0.0]
    """
    f = camera.focal
    cx, cy = camera.width / 2.0, camera.height / 2.0
    dx = (np.asarray(x, dtype=np.float64) - cx) / f
    dy = -(np.asarray(y, dtype=np.float64) - cy) / f
    t, p = math.radians(tilt), math.radians(pan)
    # Tilt about the camera's x axis, then pan about the vertical.
    yw = dy * math.cos(t) + math.sin(t)
    zt = -dy * math.sin(t) + math.cos(t)
    xw = dx * math.cos(p) + zt * math.sin(p)
    zw = -dx * math.sin(p) + zt * math.cos(p)
    return np.degrees(np.arctan2(xw, zw)), np.degrees(np.arctan2(yw, np.hypot(xw, zw)))


def angles_to_pixel(pan_w, tilt_w, pan: float, tilt: float, camera: CameraModel):
    """Pixel (x, y) where the world direction (pan_w, tilt_w) appears; NaN behind the camera.

    >>> cam = CameraModel(720, 576, 30.0)
    >>> x, y = pixel_to_angles(100.0, 50.0, 20.0, 10.0, cam)
    >>> [round(float(v), 6) for v in angles_to_pixel(x, y, 20.0, 10.0, cam)]
    [100.0, 50.0]
    """
    pw, tw = np.radians(np.asarray(pan_w, np.float64)), np.radians(np.asarray(tilt_w, np.float64))
    xw, yw, zw = np.cos(tw) * np.sin(pw), np.sin(tw), np.cos(tw) * np.cos(pw)
    t, p = math.radians(tilt), math.radians(pan)
    dx = xw * math.cos(p) - zw * math.sin(p)
    zt = xw * math.sin(p) + zw * math.cos(p)
    dy = yw * math.cos(t) - zt * math.sin(t)
    dz = yw * math.sin(t) + zt * math.cos(t)
    with np.errstate(divide="ignore", invalid="ignore"):
        dz = np.where(dz > 1e-9, dz, np.nan)
        f = camera.focal
        return camera.width / 2.0 + f * dx / dz, camera.height / 2.0 - f * dy / dz


def view_extent(pan: float, tilt: float, camera: CameraModel) -> tuple[Span, Span]:
    """(pan, tilt) ranges of every direction a frame shot at (pan, tilt) shows, traced
    along its four edges through the exact mapping: a tilted frame is no rectangle in
    angles (its far corners reach further in pan, its top or bottom edge bows).

    >>> [[round(v, 3) for v in span] for span in view_extent(0.0, 0.0, CameraModel())]
    [[-15.0, 15.0], [-12.099, 12.099]]
    """
    w, h = camera.width, camera.height
    along = np.linspace(0.0, 1.0, 33)
    xs = np.concatenate([along * w, np.full_like(along, w), along * w, np.zeros_like(along)])
    ys = np.concatenate([np.zeros_like(along), along * h, np.full_like(along, h), along * h])
    a, b = pixel_to_angles(xs, ys, pan, tilt, camera)
    return (float(a.min()), float(a.max())), (float(b.min()), float(b.max()))


@dataclass(frozen=True)
class MosaicGeometry:
    """An M×N quasi-mosaic of butted frames, each reduced ``downsample`` times.

    Tile (row i, col j) was shot at ``pan = pan0 + (j - (cols-1)/2)·step_pan`` and
    ``tilt = tilt0 - (i - (rows-1)/2)·step_tilt`` (row 0 on top); the steps default to
    the field of view, which is the seed's image butting with no overlap.
    """

    camera: CameraModel
    rows: int
    cols: int
    pan0: float = 0.0
    tilt0: float = 0.0
    downsample: float = 1.0
    step_pan: float | None = None
    step_tilt: float | None = None

    @property
    def tile_size(self) -> tuple[int, int]:
        """(width, height) of one reduced tile in the mosaic."""
        small = self.camera.scaled(self.downsample)
        return small.width, small.height

    @property
    def size(self) -> tuple[int, int]:
        w, h = self.tile_size
        return w * self.cols, h * self.rows

    def tile_pose(self, row: int, col: int) -> tuple[float, float]:
        sp = self.step_pan if self.step_pan is not None else self.camera.hfov
        st = self.step_tilt if self.step_tilt is not None else self.camera.vfov
        return (
            self.pan0 + (col - (self.cols - 1) / 2.0) * sp,
            self.tilt0 - (row - (self.rows - 1) / 2.0) * st,
        )

    @property
    def extent(self) -> tuple[Span, Span]:
        """(pan, tilt) ranges the whole mosaic shows (:func:`view_extent` of every tile)."""
        spans = [view_extent(*self.tile_pose(r, c), self.camera) for r, c in self.serpentine()]
        return (
            (min(p[0] for p, _ in spans), max(p[1] for p, _ in spans)),
            (min(t[0] for _, t in spans), max(t[1] for _, t in spans)),
        )

    def check_within(self, shown: tuple[Span, Span] | None) -> None:
        """Raise ValueError, stating both ranges, if the mosaic reaches beyond the
        directions a camera ``shown`` (None: a camera that sees wherever it points)."""
        if shown is None:
            return
        reach = self.extent
        beyond = [
            f"{axis} {value:.1f}°"
            for axis, (lo, hi), (show_lo, show_hi) in zip(
                ("pan", "tilt"), reach, shown, strict=True
            )
            for value, out in ((lo, lo < show_lo), (hi, hi > show_hi))
            if out
        ]
        if beyond:
            (p0, p1), (t0, t1) = shown
            raise ValueError(
                f"the {self.rows}×{self.cols} mosaic at pan {self.pan0:.1f}, tilt "
                f"{self.tilt0:.1f} reaches {' and '.join(beyond)}; the camera's scene shows "
                f"pan {p0:g}..{p1:g}°, tilt {t0:g}..{t1:g}°"
            )

    def to_plan(self, **extra: Any) -> dict[str, Any]:
        """The station manifest's ``plan``: this geometry as JSON-ready data (with
        ``extra`` fields such as the profile), read back by :meth:`from_plan`.

        >>> g = MosaicGeometry(CameraModel(360, 288, 30.0), 2, 3, 5.0, -1.0, 4.0)
        >>> MosaicGeometry.from_plan(g.to_plan(profile="paper")) == g
        True
        """
        return {
            "rows": self.rows,
            "cols": self.cols,
            "downsample": self.downsample,
            **extra,
            "pan0": self.pan0,
            "tilt0": self.tilt0,
            "camera": {
                "width": self.camera.width,
                "height": self.camera.height,
                "hfov": self.camera.hfov,
            },
            "mosaic": {"width": self.size[0], "height": self.size[1]},
            "order": self.serpentine(),
        }

    @classmethod
    def from_plan(cls, plan: dict[str, Any]) -> MosaicGeometry:
        """The geometry an archived ``plan`` describes (a :class:`SphericalMosaic` if it
        overlaps); KeyError or TypeError if it is not one."""
        cam = plan["camera"]
        butted = MosaicGeometry(
            CameraModel(cam["width"], cam["height"], cam["hfov"]),
            plan["rows"],
            plan["cols"],
            plan["pan0"],
            plan["tilt0"],
            plan["downsample"],
        )
        steps = plan.get("steps") or (None, None)  # a plan archived before per-axis steps
        return butted.overlapping(plan.get("overlap", 0.0), steps=tuple(steps))

    def overlapping(
        self,
        overlap: float,
        *,
        spans: tuple[int | None, int | None] = (None, None),
        steps: tuple[float | None, float | None] = (None, None),
    ) -> MosaicGeometry:
        """This plan with frames overlapping by ``overlap`` of a field of view, projected
        (:class:`SphericalMosaic`); 0 keeps them butted, the seed's way. Per axis (pan,
        tilt): the ``spans`` given are the butted fields of view this plan's tiles stretch
        across, evenly (:meth:`SphericalMosaic.spread`), so each overlaps by at least
        ``overlap``; the ``steps`` given (degrees) are the steps; neither, ``1 - overlap``
        of a field.

        >>> g = MosaicGeometry(CameraModel(), 3, 4).overlapping(0.3, spans=(3, 2))
        >>> type(g).__name__, round(g.step_pan / 30, 3), round(g.step_tilt / g.camera.vfov, 3)
        ('SphericalMosaic', 0.667, 0.5)
        """
        if overlap == 0.0:
            return self
        fovs, tiles = (self.camera.hfov, self.camera.vfov), (self.cols, self.rows)
        step_pan, step_tilt = (
            step if step is not None else SphericalMosaic.spread(span, n, fov, overlap)
            for step, span, n, fov in zip(steps, spans, tiles, fovs, strict=True)
        )
        return SphericalMosaic(
            self.camera,
            self.rows,
            self.cols,
            self.pan0,
            self.tilt0,
            self.downsample,
            step_pan,
            step_tilt,
            overlap=overlap,
        )

    def serpentine(self) -> list[tuple[int, int]]:
        """Tile order that never sweeps back across a row: left-right, then right-left.

        >>> MosaicGeometry(CameraModel(), 2, 3).serpentine()
        [(0, 0), (0, 1), (0, 2), (1, 2), (1, 1), (1, 0)]
        """
        order = []
        for r in range(self.rows):
            cols = range(self.cols) if r % 2 == 0 else range(self.cols - 1, -1, -1)
            order.extend((r, c) for c in cols)
        return order

    def to_angles(self, mx: float, my: float) -> tuple[float, float]:
        """World (pan, tilt) of a mosaic pixel: the ray through it in the tile it lies in.

        >>> g = MosaicGeometry(CameraModel(720, 576, 30.0), 2, 3, downsample=4)
        >>> [round(v, 6) for v in g.to_angles(90, 72)]  # centre of tile (0, 0)
        [-30.0, 12.098791]
        """
        w, h = self.tile_size
        col = min(max(int(mx // w), 0), self.cols - 1)
        row = min(max(int(my // h), 0), self.rows - 1)
        fx, fy = self.camera.width / w, self.camera.height / h
        x = (mx - col * w) * fx
        y = (my - row * h) * fy
        pan, tilt = self.tile_pose(row, col)
        a, b = pixel_to_angles(x, y, pan, tilt, self.camera)
        return float(a), float(b)

    def pixel_angles(self, x: float, y: float) -> tuple[float, float]:
        """World (pan, tilt) of mosaic pixel (x, y) counted as the analysis counts them
        (pixel k's centre at k, as in ``result.json``); :meth:`to_angles` puts it at k + 0.5.

        >>> g = MosaicGeometry(CameraModel(720, 576, 30.0), 2, 3, downsample=4)
        >>> g.pixel_angles(89.5, 71.5) == g.to_angles(90, 72)
        True
        """
        return self.to_angles(pixel_centre(x), pixel_centre(y))

    @property
    def degrees_per_pixel(self) -> float:
        """One mosaic pixel's width in degrees, the small-angle way (for sizes, not
        pointing)."""
        return self.camera.scaled(self.downsample).degrees_per_pixel

    def to_mosaic(self, pan_w: float, tilt_w: float) -> tuple[float, float] | None:
        """Mosaic pixel where a world direction appears, or ``None`` if no tile saw it."""
        w, h = self.tile_size
        width, height = self.camera.width, self.camera.height
        fx, fy = width / w, height / h
        for row in range(self.rows):
            for col in range(self.cols):
                pan, tilt = self.tile_pose(row, col)
                x, y = angles_to_pixel(pan_w, tilt_w, pan, tilt, self.camera)
                x, y = float(x), float(y)
                if -_SEAM <= x < width + _SEAM and -_SEAM <= y < height + _SEAM:
                    x, y = min(max(x, 0.0), width), min(max(y, 0.0), height)
                    return col * w + x / fx, row * h + y / fy
        return None


CROP_MARGIN_DEG = 0.5
"""Margin (degrees) the spherical canvas keeps inside what the planned tiles cover: where the
head's pointing errors (a few tenths of a degree) would leave a sliver uncovered."""

CROP_MARGIN_SHARE = 0.05
"""The largest share of a frame's height (vertical field of view) that margin takes. Through
a long lens (the simulated approach's 10 m station sees 1° across) 0.5° all round cropped a
2×3 mosaic's canvas to ±0.7 × ±0.2° of its butted ±1.5 × ±0.8° (a 1×1 one to nothing), and
the stain's core fell outside it; there the head's errors leave no-data slivers instead.
Through a 30° lens (24° tall) the margin stays 0.5°."""


@dataclass(frozen=True)
class SphericalMosaic(MosaicGeometry):
    """An M×N mosaic of frames overlapping by ``overlap`` of a field of view (at least: the
    steps, ``1 - overlap`` of a field unless set, may be shorter to span a butted plan's
    field, :meth:`spread`), projected onto one equirectangular (spherical) canvas: mosaic
    column ↔ pan and row ↔ tilt, linearly, at the reduced tile's resolution at its centre
    (``daemon.survey.stitch`` paints it).

    Pixel index (j, i) samples pan ``(u0 + j) / scale`` and ``π/2 - tilt`` ``(v0 + i) /
    scale`` radians, (u0, v0) being :attr:`origin`: OpenCV's spherical warper's
    coordinates, so a warped frame's corner is its place in the mosaic. The canvas is cropped
    to what the planned tiles all cover, as panorama tools crop: a frame's projected edges
    bow, and the slivers between them and a bounding box, a few pixels wide, would be
    no-data too small for the science to tell from image (``vision.nodata``) and a black step
    it would take for texture. What no frame covers (the head's errors beyond the margin) is
    no-data (black).
    """

    overlap: float = 0.3

    def __post_init__(self) -> None:
        if not 0.0 < self.overlap <= 0.5:
            raise ValueError(f"overlap must be in (0, 0.5], got {self.overlap!r}")
        keep = 1.0 - self.overlap  # steps not set: 1 - overlap of a field, the plan records them
        if self.step_pan is None:
            object.__setattr__(self, "step_pan", self.camera.hfov * keep)
        if self.step_tilt is None:
            object.__setattr__(self, "step_tilt", self.camera.vfov * keep)

    @staticmethod
    def spread(span: int | None, tiles: int, fov: float, overlap: float) -> float:
        """Degrees between ``tiles`` frames of ``fov`` degrees stretched evenly across the
        ``span`` fields of view as many butted frames cover; ``1 - overlap`` of a field
        without a span (or with one tile). ``tiles`` = :meth:`tiles` of the span keeps every
        overlap at least ``overlap``: at 0.3 a 2×3 field takes 3×4 tiles, 0.5 and 0.67 of a
        field apart, where 2×3 tiles 0.7 apart spanned 1.7×2.4 fields.

        >>> SphericalMosaic.spread(3, 4, 30.0, 0.3), SphericalMosaic.spread(None, 3, 30.0, 0.3)
        (20.0, 21.0)
        """
        if span is None or tiles < 2:
            return fov * (1.0 - overlap)
        return fov * (span - 1) / (tiles - 1)

    @staticmethod
    def tiles(fields: int, overlap: float) -> int:
        """Tiles a row (or column) of frames overlapping by ``overlap`` needs to span the
        ``fields`` fields of view that many butted frames do: ``1 + ⌈(fields - 1) / (1 -
        overlap)⌉``, at most ``2·fields - 1``. With as many tiles as butted frames a 2×3 plan
        at 0.3 spans 1.7 × 2.4 fields, and a target the approach fitted three diameters
        each way around falls outside it.

        >>> [SphericalMosaic.tiles(n, 0.3) for n in (1, 2, 3)], SphericalMosaic.tiles(3, 0.0)
        ([1, 3, 4], 3)
        """
        return 1 + math.ceil(round((fields - 1) / (1.0 - overlap), 9))

    @property
    def scale(self) -> float:
        """Mosaic pixels per radian: the reduced tile's focal length."""
        return self.camera.scaled(self.downsample).focal

    @functools.cached_property
    def _canvas(self) -> tuple[int, int, int, int]:
        """(u0, v0, width, height) of the canvas: the largest rectangle the planned tiles
        cover (their projected edges bow), less :data:`CROP_MARGIN_DEG` (at most
        :data:`CROP_MARGIN_SHARE` of a frame) all round."""
        cam, along = self.camera, np.linspace(0.0, 1.0, 33)
        edges = {  # a frame's edge as (x, y) pixel arrays, by side
            "left": (np.zeros_like(along), along * cam.height),
            "right": (np.full_like(along, cam.width), along * cam.height),
            "top": (along * cam.width, np.zeros_like(along)),
            "bottom": (along * cam.width, np.full_like(along, cam.height)),
        }

        def reach(side: str, tiles: list[tuple[int, int]]) -> np.ndarray:
            """Canvas (u, v) of ``side`` of every tile of ``tiles``, stacked."""
            pans, tilts = zip(
                *(pixel_to_angles(*edges[side], *self.tile_pose(r, c), cam) for r, c in tiles),
                strict=True,
            )
            u = self.scale * np.radians(np.concatenate(pans))
            return np.stack([u, self.scale * (math.pi / 2 - np.radians(np.concatenate(tilts)))])

        rows, cols = range(self.rows), range(self.cols)
        margin = self.scale * math.radians(min(CROP_MARGIN_DEG, CROP_MARGIN_SHARE * cam.vfov))
        u0 = math.ceil(reach("left", [(r, 0) for r in rows])[0].max() + margin)
        u1 = math.floor(reach("right", [(r, self.cols - 1) for r in rows])[0].min() - margin)
        v0 = math.ceil(reach("top", [(0, c) for c in cols])[1].max() + margin)
        v1 = math.floor(reach("bottom", [(self.rows - 1, c) for c in cols])[1].min() - margin)
        return u0, v0, u1 - u0 + 1, v1 - v0 + 1

    @property
    def origin(self) -> tuple[int, int]:
        """(u0, v0): the spherical warper's coordinates of mosaic pixel index (0, 0)."""
        return self._canvas[:2]

    @property
    def size(self) -> tuple[int, int]:
        return self._canvas[2:]

    @property
    def degrees_per_pixel(self) -> float:
        """One mosaic pixel's width in degrees (exact along the equator, in tilt everywhere)."""
        return math.degrees(1.0 / self.scale)

    def to_plan(self, **extra: Any) -> dict[str, Any]:
        """:meth:`MosaicGeometry.to_plan` plus the overlap, the (pan, tilt) steps between
        tiles (degrees) and the projection.

        >>> g = SphericalMosaic(CameraModel(360, 288, 30.0), 2, 3, 5.0, -1.0, 4.0, overlap=0.25)
        >>> MosaicGeometry.from_plan(g.to_plan(profile="default")) == g
        True
        """
        return super().to_plan(**extra) | {
            "overlap": self.overlap,
            "steps": [self.step_pan, self.step_tilt],
            "projection": "spherical",
        }

    def to_angles(self, mx: float, my: float) -> tuple[float, float]:
        """World (pan, tilt) of a mosaic pixel (continuous, pixel k's centre at k + 0.5).

        >>> g = SphericalMosaic(CameraModel(720, 576, 30.0), 2, 3, downsample=4)
        >>> [round(v, 6) for v in g.to_angles(*g.to_mosaic(-21.0, 8.5))]
        [-21.0, 8.5]
        """
        u0, v0 = self.origin
        pan = (u0 + pixel_index(mx)) / self.scale
        tilt = math.pi / 2 - (v0 + pixel_index(my)) / self.scale
        return math.degrees(pan), math.degrees(tilt)

    def to_mosaic(self, pan_w: float, tilt_w: float) -> tuple[float, float] | None:
        """Mosaic pixel where a world direction appears, or ``None`` if it lies beyond the
        canvas or no planned tile saw it."""
        u0, v0 = self.origin
        mx = pixel_centre(self.scale * math.radians(pan_w) - u0)
        my = pixel_centre(self.scale * (math.pi / 2 - math.radians(tilt_w)) - v0)
        width, height = self.size
        if not (0.0 <= mx < width and 0.0 <= my < height):
            return None
        cam = self.camera
        for row, col in self.serpentine():
            x, y = angles_to_pixel(pan_w, tilt_w, *self.tile_pose(row, col), cam)
            if -_SEAM <= float(x) < cam.width + _SEAM and -_SEAM <= float(y) < cam.height + _SEAM:
                return mx, my
        return None
