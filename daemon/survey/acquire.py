"""Acquisition: a station's tiles and chips.

Tiles are shot in serpentine order, each reduced, placed in the mosaic (butted, or
registered on the tiles before it, warped and its seams cut when they overlap: ``stitch``)
and archived while the head already moves to the next; only an overlapping mosaic's gains
and blending wait for the last tile. Chips
are full-resolution frames at the interest points, each saved and published while the head
moves on.
"""

from __future__ import annotations

import asyncio
import functools
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from cyborg.protocol.messages import Chip, InterestPoint

from ..archive import Station
from ..camera import Frame
from ..pointing.geometry import MosaicGeometry, SphericalMosaic
from ..ptu import PtuInfo, PtuLimitError, PtuPosition
from ..rig import Rig
from ..vision.imageio import encode_image
from .refine import Centring, approach, measure
from .stitch import Stitcher

__all__ = ["CHIPS", "Acquisition", "check_reach"]

_LOGGER = logging.getLogger(__name__)

CHIPS = 3

_Pending = tuple[int, int, Frame, tuple[float, float]]
"""A tile shot but not yet placed: row, column, frame, pose."""


def check_reach(geometry: MosaicGeometry, info: PtuInfo) -> None:
    """Raise PtuLimitError if a tile of the plan lies outside the unit's limits."""
    for r, c in geometry.serpentine():
        pan, tilt = geometry.tile_pose(r, c)
        if info.limits_enabled and not (
            info.pan.min_deg <= pan <= info.pan.max_deg
            and info.tilt.min_deg <= tilt <= info.tilt.max_deg
        ):
            raise PtuLimitError(
                "plan",
                f"tile ({r}, {c}) at pan {pan:.1f}, tilt {tilt:.1f} deg is outside the "
                f"unit's limits (pan {info.pan.min_deg:.1f}..{info.pan.max_deg:.1f}, "
                f"tilt {info.tilt.min_deg:.1f}..{info.tilt.max_deg:.1f})",
            )


@dataclass
class Acquisition:
    """One station's shooting: ``timing`` adds up the predicted motion and the grabbing;
    ``progress(stage, done, total[, eta])`` reports each step."""

    rig: Rig
    settle: float
    """Seconds for the tripod to settle once the head stops."""
    timing: dict[str, float]
    progress: Callable[..., None]

    async def _settle_and_grab(self) -> tuple[PtuPosition, Frame]:
        """Wait for the head to stop (and the tripod to settle), then take a frame."""
        position = await self.rig.settle()
        if self.settle:
            await asyncio.sleep(self.settle)
        tg = time.perf_counter()
        frame = await self.rig.grab()
        self.timing["grab_s"] += time.perf_counter() - tg
        return position, frame

    async def tiles(
        self, station: Station, geometry: MosaicGeometry, analysis_s: float
    ) -> np.ndarray:
        """Shoot, place and archive every tile, then the mosaic; ``analysis_s`` (the last
        analysis's duration) goes into the time left announced."""
        width, height = geometry.size
        mosaic = np.zeros((height, width, 3), np.uint8)
        order = geometry.serpentine()
        ptu = self.rig.ptu
        stitcher = Stitcher(geometry) if isinstance(geometry, SphericalMosaic) else None
        place: Callable[[_Pending], None] = (
            functools.partial(_register, station, stitcher)
            if stitcher is not None
            else functools.partial(_place, station, mosaic, geometry.tile_size)
        )
        pending: _Pending | None = None
        t0 = time.perf_counter()
        try:
            for k, (row, col) in enumerate(order):
                pan, tilt = geometry.tile_pose(row, col)
                self.timing["predicted_motion_s"] += ptu.predict_move_time(pan, tilt)
                await ptu.move_to(pan, tilt, wait=False)
                self.rig.mark_moving()
                if pending is not None:  # reduce, place and archive the last tile while moving
                    job, pending = pending, None
                    await asyncio.to_thread(place, job)
                position, frame = await self._settle_and_grab()
                pending = (row, col, frame, (position.pan, position.tilt))
                per_tile = (time.perf_counter() - t0) / (k + 1)
                eta = per_tile * (len(order) - k - 1 + CHIPS) + analysis_s
                self.progress("tiles", k + 1, len(order), round(eta, 1))
        except asyncio.CancelledError:
            if pending is not None:  # a frame already taken is kept
                place(pending)
            raise
        if pending is not None:
            await asyncio.to_thread(place, pending)
        if stitcher is not None:
            tc = time.perf_counter()
            mosaic = await asyncio.to_thread(stitcher.compose)
            self.timing["compose_s"] = time.perf_counter() - tc
        await asyncio.to_thread(station.write_png, "mosaic.png", mosaic)
        return mosaic

    async def chips(
        self,
        station: Station,
        station_id: str,
        points: list[InterestPoint],
        publish: Callable[[Chip], None],
        reference: tuple[np.ndarray, MosaicGeometry] | None = None,
    ) -> None:
        """Re-point at each of the first :data:`CHIPS` targets and take a full-resolution
        frame; each chip is saved and published while the head already moves to the next.
        A point marked "no further target" (``target`` false) is not looked at again.

        With a ``reference`` (the station's mosaic and geometry) each chip is registered to
        it and, if off its target by more than ``refine.CORRECTION_THRESHOLD``, the head is
        corrected once and the chip retaken; the chip's record says how far off it was."""
        ptu = self.rig.ptu
        chosen = [p for p in points if p.target][:CHIPS]
        saving: asyncio.Task[Chip] | None = None
        for k, point in enumerate(chosen):
            self.progress("chips", k, len(chosen))
            came_from = self.rig.pose
            self.timing["predicted_motion_s"] += ptu.predict_move_time(point.pan, point.tilt)
            await ptu.move_to(point.pan, point.tilt, wait=False)
            self.rig.mark_moving()
            if saving is not None:
                publish(await saving)
            position, frame = await self._settle_and_grab()
            centring: dict[str, object] = {}
            if reference is not None:
                position, frame, centring = await self._centre(
                    point, came_from, position, frame, reference
                )
            saving = asyncio.create_task(
                asyncio.to_thread(
                    _save_chip,
                    station,
                    station_id,
                    point,
                    (position.pan, position.tilt),
                    frame,
                    centring=centring,
                ),
                name="cyborgd.survey.save-chip",
            )
        if saving is not None:
            publish(await saving)
        self.progress("chips", len(chosen), len(chosen))

    async def _centre(
        self,
        point: InterestPoint,
        came_from: PtuPosition,
        position: PtuPosition,
        frame: Frame,
        reference: tuple[np.ndarray, MosaicGeometry],
    ) -> tuple[PtuPosition, Frame, dict[str, object]]:
        """Measure a chip's centring on the mosaic; correct the head once and retake it if
        it is off, arriving from the side it came from (backlash). The chip kept, and its
        record: ``before_deg``, ``after_deg`` (the kept chip's; None: not measurable),
        ``confidence``, ``uncertainty_deg`` (of ``before_deg``), ``corrected``."""
        target = (point.pan, point.tilt)

        def centring(position: PtuPosition, frame: Frame) -> Centring | None:
            return measure(frame.image, (position.pan, position.tilt), target, *reference)

        before = await asyncio.to_thread(centring, position, frame)
        error = None if before is None else round(before.error, 4)
        record: dict[str, object] = {"before_deg": error, "after_deg": error, "corrected": False}
        record["confidence"] = 0.0 if before is None else round(before.confidence, 3)
        record["uncertainty_deg"] = None if before is None else round(before.uncertainty, 4)
        if before is None or not before.needs_correction:
            return position, frame, record
        here = (position.pan, position.tilt)
        goal = (here[0] + before.offset[0], here[1] + before.offset[1])
        ptu = self.rig.ptu
        try:
            for pan, tilt in approach(here, (came_from.pan, came_from.tilt), goal):
                self.timing["predicted_motion_s"] += ptu.predict_move_time(pan, tilt)
                await self.rig.move_to(pan, tilt)
        except PtuLimitError as exc:  # the chip already taken stands
            _LOGGER.info("chip %d not corrected: %s", point.rank, exc)
            return position, frame, record
        position, frame = await self._settle_and_grab()
        after = await asyncio.to_thread(centring, position, frame)
        record.update(corrected=True, after_deg=None if after is None else round(after.error, 4))
        return position, frame, record


def _place(station: Station, mosaic: np.ndarray, tile: tuple[int, int], pending: _Pending) -> None:
    row, col, frame, (pan, tilt) = pending
    tw, th = tile
    image = frame.image
    small = cv2.resize(image, (tw, th), interpolation=cv2.INTER_AREA)
    mosaic[row * th : (row + 1) * th, col * tw : (col + 1) * tw] = small
    station.add_tile(row, col, image, (pan, tilt), frame.timestamp)


def _register(station: Station, stitcher: Stitcher, pending: _Pending) -> None:
    """Register a tile on those placed before it, warp it and cut its seams with them;
    archive it with its correction."""
    row, col, frame, pose = pending
    fit = stitcher.add(row, col, frame.image, pose)
    station.add_tile(row, col, frame.image, pose, frame.timestamp, registration=fit.record())


def _save_chip(
    station: Station,
    station_id: str,
    point: InterestPoint,
    pose: tuple[float, float],
    frame: Frame,
    *,
    centring: dict[str, object],
) -> Chip:
    extra = {"centring": centring} if centring else {}
    rel = station.add_chip(point.rank, frame.image, pose, frame.timestamp, **extra)
    return Chip(station_id, point.rank, *pose, rel, encode_image(frame.image, quality=85))
