"""Registering a station to the one it was aimed from: predicted from geometry, refined by
image registration, the residual reported (how far the prediction was off).

Prediction. Each pixel of the new mosaic is a world direction (its geometry). Zooming
from the same tripod, the earlier mosaic saw that direction as is. Walking ``k`` times
closer to a roughly planar outcrop, directions spread away from the target's by ``k``, so
the earlier station saw ``target + (direction - target) / k``. Either way the earlier
mosaic is resampled into the new one's frame.

Refinement. OpenCV's ECC (enhanced correlation coefficient) finds the similarity
(shift, scale, rotation) that best aligns the prediction with what the new station shot,
on a reduced grey copy; the residual is that correction, in pixels and degrees, and the
correlation reached says how much to trust it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from ..archive import Archive, ArchiveError
from ..pointing.geometry import MosaicGeometry, pixel_centre
from .approach import Previous

__all__ = ["Frame", "carry", "register", "register_to"]

_WORK = 256
"""Longest side of the copies registered (coarse structure is what carries across)."""


@dataclass(frozen=True)
class Frame:
    """Where a station's directions lie in a reference station's (the session's first):
    ``reference = offset + scale x direction``, pan and tilt alike. Walking ``k`` times
    closer to a target divides the spread about it by ``k`` (the prediction above, which
    :func:`carry` applies pixel by pixel); zooming or staying put changes nothing. So a
    chain of walks (300 -> 60 -> 10 m) composes into one such map, and any two stations of
    it map into each other."""

    scale: float = 1.0
    pan: float = 0.0
    tilt: float = 0.0

    def walked(self, target: tuple[float, float], walk: float) -> Frame:
        """The frame of a station aimed from this one at ``target``, ``walk`` times closer:
        it sees direction d where this one saw ``target + (d - target) / walk``."""
        spread = self.scale * (1.0 - 1.0 / walk)
        return Frame(
            self.scale / walk, self.pan + spread * target[0], self.tilt + spread * target[1]
        )

    def into(self, other: Frame, pan: float, tilt: float) -> tuple[float, float]:
        """The direction in which the station of frame ``other`` saw this one's (pan, tilt)."""
        ref_pan, ref_tilt = self.pan + self.scale * pan, self.tilt + self.scale * tilt
        return (ref_pan - other.pan) / other.scale, (ref_tilt - other.tilt) / other.scale


def carry(
    old: np.ndarray,
    old_geo: MosaicGeometry,
    new_geo: MosaicGeometry,
    *,
    target: tuple[float, float],
    walk: float,
    size: tuple[int, int],
) -> np.ndarray:
    """A map of the earlier mosaic (one plane, any values, shaped as the earlier mosaic or
    reduced from it) as the new station sees it, (h, w) float32 for ``size`` = (w, h);
    NaN where the earlier one saw nothing."""
    w, h = size
    sx, sy = new_geo.size[0] / w, new_geo.size[1] / h
    ox, oy = old.shape[1] / old_geo.size[0], old.shape[0] / old_geo.size[1]
    out = np.full((h, w), np.nan, np.float32)
    plane = old.astype(np.float32, copy=False)
    for y in range(h):
        for x in range(w):
            pan, tilt = new_geo.to_angles(pixel_centre(x) * sx, pixel_centre(y) * sy)
            pan = target[0] + (pan - target[0]) / walk
            tilt = target[1] + (tilt - target[1]) / walk
            seen = old_geo.to_mosaic(pan, tilt)
            if seen is not None:
                u, v = seen[0] * ox, seen[1] * oy
                if 0 <= u < plane.shape[1] - 1 and 0 <= v < plane.shape[0] - 1:
                    out[y, x] = plane[int(v), int(u)]
    return out


def register(
    old: np.ndarray,
    old_geo: MosaicGeometry,
    new: np.ndarray,
    new_geo: MosaicGeometry,
    *,
    target: tuple[float, float],
    walk: float,
) -> dict[str, Any]:
    """The registration record for the new station's manifest: the prediction used, the
    residual correction (pixels of the new mosaic, and degrees) and the correlation."""
    rows, cols = new.shape[:2]
    scale = _WORK / max(rows, cols)
    size = (max(8, round(cols * scale)), max(8, round(rows * scale)))
    coarse = (size[0] // 4, size[1] // 4)
    grey = cv2.cvtColor(old, cv2.COLOR_BGR2GRAY)
    predicted = carry(grey, old_geo, new_geo, target=target, walk=walk, size=coarse)
    predicted = cv2.resize(predicted, size, interpolation=cv2.INTER_LINEAR)
    seen = np.isfinite(predicted)
    record: dict[str, Any] = {"prediction": "walk" if walk > 1.0 else "zoom", "overlap": 0.0}
    record["overlap"] = round(float(seen.mean()), 3)
    if seen.mean() < 0.1:
        record["note"] = "the earlier station saw too little of this one to register"
        return record
    shot = cv2.resize(cv2.cvtColor(new, cv2.COLOR_BGR2GRAY), size, interpolation=cv2.INTER_AREA)
    template = np.where(seen, predicted, shot.mean()).astype(np.float32)
    warp = np.eye(2, 3, dtype=np.float32)
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-5)
    try:
        rho, warp = cv2.findTransformECC(
            template,
            shot.astype(np.float32),
            warp,
            cv2.MOTION_AFFINE,
            criteria,
            seen.astype(np.uint8),
            5,
        )
    except cv2.error:
        record["note"] = "image registration did not converge; the prediction stands"
        return record
    shift = (float(warp[0, 2]) / scale, float(warp[1, 2]) / scale)
    deg_per_px = new_geo.degrees_per_pixel
    record.update(
        shift_px=[round(shift[0], 2), round(shift[1], 2)],
        shift_deg=round(math.hypot(*shift) * deg_per_px, 4),
        scale=round(float(math.sqrt(abs(np.linalg.det(warp[:, :2])))), 4),
        correlation=round(float(rho), 4),
    )
    return record


def register_to(
    previous: Previous, archive: Archive, mosaic: np.ndarray, geometry: MosaicGeometry
) -> dict[str, Any]:
    """The manifest's ``registration`` of a station (``mosaic`` shot as ``geometry``) to the
    one it was aimed from, residual included; a failure is noted in it, not raised."""
    try:
        old_geo = previous.geometry(archive)
        old = previous.image(archive, "mosaic.png", cv2.IMREAD_COLOR, "mosaic")
        record = register(
            old, old_geo, mosaic, geometry, target=previous.target, walk=previous.walk
        )
    except (ArchiveError, cv2.error, ValueError) as exc:
        record = {"note": f"not registered: {exc}"}
    return {"from": previous.station, **record}
