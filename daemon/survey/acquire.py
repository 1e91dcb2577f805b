"""Acquisition: a station's tiles and chips.

Tiles are shot in serpentine order, each reduced, placed in the mosaic (butted, or
registered on the tiles before it, warped and its seams cut when they overlap: ``stitch``)
and archived while the head already moves to the next; only the last tile's placing and an
overlapping mosaic's gains and blending wait for the last tile, its archiving and the
mosaic's are left to run while the mosaic is analysed. Chips are full-resolution frames at
the interest points: the mosaic is warped to the view each should show while the head is on
its way (``refine.expect``), and each is saved and published while the head moves on.
"""

from __future__ import annotations

import asyncio
import functools
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from cyborg.protocol.messages import Chip, InterestPoint

from ..archive import Station
from ..camera import Frame
from ..pointing.geometry import MosaicGeometry, SphericalMosaic
from ..ptu import PtuInfo, PtuLimitError, PtuPosition
from ..rig import Rig
from ..vision.imageio import encode_image
from .refine import Centring, View, approach, expect
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
    stitcher: Stitcher | None = None
    """The last registered mosaic's, once :meth:`tiles` composed it: chips are aimed through
    the tiles that show their targets (:meth:`Stitcher.correction_at`)."""

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
    ) -> tuple[np.ndarray, Callable[[], None]]:
        """Shoot, place and archive every tile; the mosaic, and what is left to archive (the
        last tile and the mosaic, fsynced and listed) for the caller to run, in a thread,
        while the mosaic is analysed. ``analysis_s`` (the last analysis's duration) goes into
        the time left announced."""
        width, height = geometry.size
        mosaic = np.zeros((height, width, 3), np.uint8)
        order = geometry.serpentine()
        ptu = self.rig.ptu
        stitcher = Stitcher(geometry) if isinstance(geometry, SphericalMosaic) else None
        self.stitcher = None
        put: Callable[[_Pending], dict[str, Any]] = (
            functools.partial(_register, stitcher)
            if stitcher is not None
            else functools.partial(_place, mosaic, geometry.tile_size)
        )

        def place(job: _Pending) -> None:
            _archive(station, job, put(job))

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
        last, fields = pending, dict[str, Any]()
        try:
            if last is not None:
                fields = await asyncio.to_thread(put, last)
            if stitcher is not None:
                tc = time.perf_counter()
                mosaic = await asyncio.to_thread(stitcher.compose)
                self.timing["compose_s"] = time.perf_counter() - tc
                self.stitcher = stitcher
        except asyncio.CancelledError:
            if last is not None:
                _archive(station, last, fields)
            raise

        def rest() -> None:
            if last is not None:
                _archive(station, last, fields)
            station.write_png("mosaic.png", mosaic)

        return mosaic, rest

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

        A point's angles are in the mosaic's frame; on a registered mosaic the head is sent
        there through the tile that shows it (:attr:`stitcher`), as that tile's pose was off.
        With a ``reference`` (the station's mosaic and geometry) each chip is registered to
        it and, if off its target by more than ``refine.CORRECTION_THRESHOLD``, the head is
        corrected once and the chip retaken; the chip's record says how far off it was and
        the tile's correction it was aimed through (``tile_correction_deg``)."""
        ptu = self.rig.ptu
        chosen = [p for p in points if p.target][:CHIPS]
        saving: asyncio.Task[Chip] | None = None
        for k, point in enumerate(chosen):
            self.progress("chips", k, len(chosen))
            came_from, target = self.rig.pose, (point.pan, point.tilt)
            shift = (0.0, 0.0) if self.stitcher is None else self.stitcher.correction_at(*target)
            goal = (target[0] - shift[0], target[1] - shift[1])
            self.timing["predicted_motion_s"] += ptu.predict_move_time(*goal)
            await ptu.move_to(*goal, wait=False)
            self.rig.mark_moving()
            view = None if reference is None else self._expect(goal, shift, target, reference)
            try:
                if saving is not None:
                    publish(await saving)
                position, frame = await self._settle_and_grab()
                centring: dict[str, object] = {}
                if reference is not None and view is not None:
                    position, frame, centring = await self._centre(
                        point, came_from, position, frame, shift, reference=reference, view=view
                    )
            finally:
                if view is not None:
                    view.cancel()
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

    def _expect(
        self,
        goal: tuple[float, float],
        shift: tuple[float, float],
        target: tuple[float, float],
        reference: tuple[np.ndarray, MosaicGeometry],
    ) -> asyncio.Task[View | None]:
        """Warp the mosaic to what a chip of ``target`` should show from where the head
        lands for ``goal`` (that pose plus ``shift`` in the mosaic's frame), while it is on
        its way there (``refine.expect``)."""
        pose, size = _shifted(self.rig.landing(*goal), shift), self.rig.camera.resolution
        return asyncio.create_task(
            asyncio.to_thread(expect, pose, target, size, *reference),
            name="cyborgd.survey.expect",
        )

    async def _centre(
        self,
        point: InterestPoint,
        came_from: PtuPosition,
        position: PtuPosition,
        frame: Frame,
        shift: tuple[float, float],
        *,
        reference: tuple[np.ndarray, MosaicGeometry],
        view: asyncio.Task[View | None],
    ) -> tuple[PtuPosition, Frame, dict[str, object]]:
        """Measure a chip's centring on the mosaic (``view``: the mosaic warped to where the
        head was to land, its pose plus ``shift`` in the mosaic's frame); correct the head
        once and retake it if it is off, arriving from the side it came from (backlash). The
        chip kept, and its record: ``before_deg``, ``after_deg`` (the kept chip's; None: not
        measurable), ``confidence``, ``uncertainty_deg`` (of ``before_deg``), ``corrected``,
        ``tile_correction_deg``."""
        target = (point.pan, point.tilt)
        before = await _measure(await view, _shifted(position, shift), frame, target, reference)
        error = None if before is None else round(before.error, 4)
        record: dict[str, object] = {"before_deg": error, "after_deg": error, "corrected": False}
        record["confidence"] = 0.0 if before is None else round(before.confidence, 3)
        record["uncertainty_deg"] = None if before is None else round(before.uncertainty, 4)
        record["tile_correction_deg"] = [round(v, 5) for v in shift]
        if before is None or not before.needs_correction:
            return position, frame, record
        here = (position.pan, position.tilt)
        goal = (here[0] + before.offset[0], here[1] + before.offset[1])
        ptu = self.rig.ptu
        view = self._expect(goal, shift, target, reference)
        try:
            for pan, tilt in approach(here, (came_from.pan, came_from.tilt), goal):
                self.timing["predicted_motion_s"] += ptu.predict_move_time(pan, tilt)
                await self.rig.move_to(pan, tilt)
            position, frame = await self._settle_and_grab()
            after = await _measure(await view, _shifted(position, shift), frame, target, reference)
        except PtuLimitError as exc:  # the chip already taken stands
            _LOGGER.info("chip %d not corrected: %s", point.rank, exc)
            return position, frame, record
        finally:
            view.cancel()
        record.update(corrected=True, after_deg=None if after is None else round(after.error, 4))
        return position, frame, record


def _shifted(
    pose: PtuPosition | tuple[float, float], shift: tuple[float, float]
) -> tuple[float, float]:
    """A pose the head reports, in the mosaic's frame: ``shift`` (the correction of the tile
    it is aimed through) added."""
    pan, tilt = (pose.pan, pose.tilt) if isinstance(pose, PtuPosition) else pose
    return pan + shift[0], tilt + shift[1]


async def _measure(
    view: View | None,
    pose: tuple[float, float],
    frame: Frame,
    target: tuple[float, float],
    reference: tuple[np.ndarray, MosaicGeometry],
) -> Centring | None:
    """``frame``'s centring on ``view``, or on a view made anew if the head reported
    another ``pose`` (in the mosaic's frame) than the one it was to land at (a stall, a
    mechanical stop) or the frame is of another size."""
    height, width = frame.image.shape[:2]
    if view is None or view.pose != pose or view.size != (width, height):
        view = await asyncio.to_thread(expect, pose, target, (width, height), *reference)
    return None if view is None else await asyncio.to_thread(view.measure, frame.image)


def _place(mosaic: np.ndarray, tile: tuple[int, int], pending: _Pending) -> dict[str, Any]:
    """Reduce a tile into its slot of a butted mosaic; nothing to add to its record."""
    row, col, frame, _ = pending
    tw, th = tile
    small = cv2.resize(frame.image, (tw, th), interpolation=cv2.INTER_AREA)
    mosaic[row * th : (row + 1) * th, col * tw : (col + 1) * tw] = small
    return {}


def _register(stitcher: Stitcher, pending: _Pending) -> dict[str, Any]:
    """Register a tile on those placed before it, warp it and cut its seams with them; its
    correction, for its record."""
    row, col, frame, pose = pending
    return {"registration": stitcher.add(row, col, frame.image, pose).record()}


def _archive(station: Station, pending: _Pending, fields: dict[str, Any]) -> None:
    """Archive a tile as shot and list it, with ``fields``."""
    row, col, frame, pose = pending
    station.add_tile(row, col, frame.image, pose, frame.timestamp, **fields)


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
