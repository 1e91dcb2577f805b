"""Acquisition: a station's tiles and chips.

Tiles are shot in serpentine order, each reduced, placed in the mosaic and archived while
the head already moves to the next; chips are full-resolution frames at the interest
points, each saved and published while the head moves on.
"""

from __future__ import annotations

import asyncio
import functools
import time
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from cyborg.protocol.messages import Chip, InterestPoint

from ..archive import Station
from ..camera import Frame
from ..pointing.geometry import MosaicGeometry
from ..ptu import PtuInfo, PtuLimitError, PtuPosition
from ..rig import Rig
from ..vision.imageio import encode_image

__all__ = ["CHIPS", "Acquisition", "check_reach"]

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
        place = functools.partial(_place, station, mosaic, geometry.tile_size)
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
        await asyncio.to_thread(station.write_png, "mosaic.png", mosaic)
        return mosaic

    async def chips(
        self,
        station: Station,
        station_id: str,
        points: list[InterestPoint],
        publish: Callable[[Chip], None],
    ) -> None:
        """Re-point at each of the first :data:`CHIPS` targets and take a full-resolution
        frame; each chip is saved and published while the head already moves to the next.
        A point marked "no further target" (``target`` false) is not looked at again."""
        ptu = self.rig.ptu
        chosen = [p for p in points if p.target][:CHIPS]
        saving: asyncio.Task[Chip] | None = None
        for k, point in enumerate(chosen):
            self.progress("chips", k, len(chosen))
            self.timing["predicted_motion_s"] += ptu.predict_move_time(point.pan, point.tilt)
            await ptu.move_to(point.pan, point.tilt, wait=False)
            self.rig.mark_moving()
            if saving is not None:
                publish(await saving)
            position, frame = await self._settle_and_grab()
            saving = asyncio.create_task(
                asyncio.to_thread(
                    _save_chip, station, station_id, point, (position.pan, position.tilt), frame
                ),
                name="cyborgd.survey.save-chip",
            )
        if saving is not None:
            publish(await saving)
        self.progress("chips", len(chosen), len(chosen))


def _place(station: Station, mosaic: np.ndarray, tile: tuple[int, int], pending: _Pending) -> None:
    row, col, frame, (pan, tilt) = pending
    tw, th = tile
    image = frame.image
    small = cv2.resize(image, (tw, th), interpolation=cv2.INTER_AREA)
    mosaic[row * th : (row + 1) * th, col * tw : (col + 1) * tw] = small
    station.add_tile(row, col, image, (pan, tilt), frame.timestamp)


def _save_chip(
    station: Station,
    station_id: str,
    point: InterestPoint,
    pose: tuple[float, float],
    frame: Frame,
) -> Chip:
    rel = station.add_chip(point.rank, frame.image, pose, frame.timestamp)
    return Chip(station_id, point.rank, *pose, rel, encode_image(frame.image, quality=85))
