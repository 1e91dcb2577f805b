"""The survey state machine: plan, acquire, analyse, chips, choose, next station.

One station: shoot an M×N mosaic of butted frames in serpentine order, reducing and
placing each tile while the head already moves to the next; hand the mosaic to the
vision worker; re-point at the top three interest points for full-resolution chips;
publish the result and wait for the operator's choice. Choosing a target aims the next
station at it, one step closer along the approach (the seed's 300 m -> 60 m -> 10 m).
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import json
import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from enum import StrEnum
from typing import Any

import cv2
import numpy as np

from cyborg.protocol.messages import (
    Chip,
    ChooseTarget,
    InterestPoint,
    InterestResult,
    SurveyProgress,
    SurveyStart,
)

from ..archive import MANIFEST, Archive, ArchiveError, Station
from ..camera import CameraError, Frame
from ..config import SurveyConfig
from ..pointing.geometry import CameraModel, MosaicGeometry
from ..ptu import PtuError, PtuLimitError, PtuPosition
from ..rig import Rig
from ..vision.imageio import encode_image
from ..vision.params import PROFILES, with_settings
from ..worker import VisionWorker, WorkerError
from .memory import SessionMemory, phrase, station_prior
from .register import register
from .report import write_report
from .site import Orientation

__all__ = ["ANALYSE", "Survey", "SurveyBusyError", "SurveyState", "SurveyTelemetry"]

_LOGGER = logging.getLogger(__name__)

ANALYSE = "cyborg.daemon.vision.job:analyse_into"
"""The worker's job, by name: the service process never imports the science core."""

CHIPS = 3


class SurveyBusyError(RuntimeError):
    """A survey is already running."""


class SurveyState(StrEnum):
    """Where the engine stands; the status message carries the value."""

    IDLE = "idle"
    """No station running and no choice awaited: a survey may start."""
    SURVEYING = "surveying"
    """A station is planning, acquiring, analysing or shooting chips."""
    AWAITING_CHOICE = "awaiting-choice"
    """A station finished; its points wait for the operator to choose where to go next."""


@dataclass
class SurveyTelemetry:
    """Where the survey reports; the app wires these to the bus."""

    progress: Callable[[SurveyProgress], None]
    result: Callable[[InterestResult], None]
    chip: Callable[[Chip], None]
    event: Callable[[str, str], None]


@dataclass
class _Approach:
    """Where the approach loop stands between stations."""

    session: str = ""
    index: int = 0
    leg: int = 0
    aim: tuple[float, float] | None = None
    aimed_from: str = ""
    radius_deg: float = 0.0
    """The aimed target's angular radius, as the station it was chosen at saw it."""
    mosaic: tuple[int, int] | None = None
    """(rows, cols) fitted to the aimed target's size."""


class Survey:
    def __init__(
        self,
        rig: Rig,
        worker: VisionWorker,
        archive: Archive,
        config: SurveyConfig,
        *,
        hfov: float,
        telemetry: SurveyTelemetry,
        orientation: Orientation | None = None,
        site: Callable[[], dict[str, Any]] | None = None,
    ) -> None:
        """``orientation`` turns pan/tilt into azimuth/elevation; ``site`` says where the
        rig stands when a station starts (daemon.site.where)."""
        self.rig, self.worker, self.archive, self.cfg = rig, worker, archive, config
        self.hfov = hfov
        self.tel = telemetry
        self.orientation = orientation or Orientation(None)
        self.site = site or (lambda: {})
        self.state: SurveyState = SurveyState.IDLE
        self.station: Station | None = None
        self.last_error = ""
        self._task: asyncio.Task[None] | None = None
        self._approach = _Approach()
        self._result: InterestResult | None = None
        self._analysis_estimate = 1.0
        self._last_centre: tuple[float, float] | None = None
        self.memory = SessionMemory()
        """What this session's earlier stations showed (novelty against history)."""

    # -- commands ----------------------------------------------------------------------

    @property
    def running(self) -> bool:
        return self._task is not None and not self._task.done()

    @property
    def awaiting_result(self) -> InterestResult | None:
        """The result a choice is awaited for, if one is."""
        return self._result if self.state == SurveyState.AWAITING_CHOICE else None

    @property
    def distance(self) -> float:
        return self.cfg.approach[self._approach.leg]

    def start(self, req: SurveyStart, requested_by: str) -> str:
        """Plan and launch a station; returns its id. Raises before touching anything if
        the plan leaves the unit's limits or a survey runs."""
        if self.running:
            raise SurveyBusyError(f"station {self.station_id} is still running")
        c = self.cfg
        rows, cols = self._approach.mosaic or (c.rows, c.cols)  # fitted to the aimed target
        req = replace(
            req,
            rows=rows if req.rows is None else req.rows,
            cols=cols if req.cols is None else req.cols,
            downsample=c.downsample if req.downsample is None else req.downsample,
            profile=c.profile if req.profile is None else req.profile,
            settings=c.settings if req.settings is None else req.settings,
        )
        geometry = self._plan(req)
        self._last_centre = (geometry.pan0, geometry.tilt0)
        ap = self._approach
        if not ap.session:
            ap.session, ap.index = self.archive.new_session(), 0
            self.memory.clear()
        ap.index += 1
        plan = geometry.to_plan(profile=req.profile, settings=list(req.settings or ()))
        self.station = self.archive.new_station(
            ap.session,
            ap.index,
            self.distance,
            plan=plan,
            site=self.site(),
            requested_by=requested_by,
            aim={"pan": ap.aim[0], "tilt": ap.aim[1], "from": ap.aimed_from} if ap.aim else None,
            tiles=[],
            chips=[],
            points=[],
            choice=None,
            timing={},
        )
        self.state, self.last_error, self._result = SurveyState.SURVEYING, "", None
        self._task = asyncio.create_task(
            self._run(geometry, req.profile, req.settings or ()), name="cyborgd.survey.run"
        )
        return self.station_id

    @property
    def station_id(self) -> str:
        return f"{self._approach.session}/{self.station.name}" if self.station else ""

    def _plan(self, req: SurveyStart) -> MosaicGeometry:
        if req.profile not in PROFILES:
            raise ValueError(f"unknown profile {req.profile!r}; known: {', '.join(PROFILES)}")
        try:  # before anything moves: a typo is an error now, not a failed station later
            with_settings(PROFILES[req.profile], list(req.settings or ()))
        except ValueError as exc:
            raise ValueError(f"settings: {exc}") from None
        ap = self._approach
        # The centre is always a decision: asked for, aimed at, surveyed before, or set up.
        default = ap.aim or self._last_centre or (self.cfg.pan0, self.cfg.tilt0)
        pan0 = req.pan0 if req.pan0 is not None else default[0]
        tilt0 = req.tilt0 if req.tilt0 is not None else default[1]
        geometry = MosaicGeometry(
            self.live_camera(), req.rows, req.cols, pan0, tilt0, req.downsample
        )
        info = self.rig.ptu.info
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
        return geometry

    def live_camera(self) -> CameraModel:
        """The camera's optics as they are now (a simulated approach magnifies them)."""
        width, height = self.rig.camera.resolution
        return CameraModel(width, height, self.hfov).zoomed(self._magnification())

    def geometry_of(self, station_id: str) -> MosaicGeometry:
        """How a station's mosaic maps to angles, from its archived plan."""
        session, _, name = station_id.partition("/")
        try:
            plan = json.loads(self.archive.read(session, f"{name}/{MANIFEST}", 1 << 20))["plan"]
            return MosaicGeometry.from_plan(plan)
        except (ValueError, KeyError, TypeError) as exc:
            raise ArchiveError(f"station {station_id}: no usable plan ({exc})") from None

    def _magnification(self) -> float:
        """How much closer the approach has brought the view, when it zooms rather than
        walks (intelligent zoom, or a simulation)."""
        if not (self.cfg.simulate_approach or self.cfg.zoom_on_target):
            return 1.0
        return self.cfg.approach[0] / self.distance

    async def cancel(self, reason: str) -> bool:
        task = self._task
        if task is None or task.done():
            return False
        task.cancel(reason)
        with contextlib.suppress(asyncio.CancelledError):
            await task
        return True

    async def choose(self, msg: ChooseTarget, by: str) -> str:
        """Record the operator's choice; aim the next station at it, one leg closer."""
        result = self._result
        if self.state != SurveyState.AWAITING_CHOICE or result is None or self.station is None:
            raise ValueError("no station is waiting for a choice")
        if msg.station != result.station:
            raise ValueError(f"station {msg.station!r} is not the one waiting ({result.station})")
        ap = self._approach
        if msg.rank == 0:
            self.station.update(choice={"rank": 0, "by": by, "t": time.time()})
            await self._report(self.station)
            ap.aim, ap.aimed_from, ap.mosaic = None, "", None
            self.state = SurveyState.IDLE
            return f"no target chosen at {result.station}; next station at {self.distance:g} m"
        point = next((p for p in result.points if p.rank == msg.rank), None)
        if point is None:
            raise ValueError(f"station {result.station} has no point of rank {msg.rank}")
        self.station.update(
            choice={
                "rank": point.rank,
                "pan": point.pan,
                "tilt": point.tilt,
                "by": by,
                "t": time.time(),
            }
        )
        await self._report(self.station)
        self.state = SurveyState.IDLE
        if ap.leg + 1 >= len(self.cfg.approach):
            self._approach = _Approach()
            await self.rig.move_to(point.pan, point.tilt)
            return f"target {point.rank} chosen at the last station; next survey: new session"
        ratio = self.distance / self.cfg.approach[ap.leg + 1]
        ap.leg += 1
        ap.aim, ap.aimed_from = (point.pan, point.tilt), f"{result.station}#{point.rank}"
        ap.radius_deg = point.radius_deg or 0.0
        ap.mosaic, fit = self._fit(point, ratio)
        self.station.update(choice=self.station.manifest["choice"] | {"next": fit})
        if self.cfg.simulate_approach or self.cfg.zoom_on_target:
            level = self._magnification()
            seconds = await self.rig.camera.zoom(level)
            zoom = {"level": round(level, 4), "seconds": round(seconds, 3)}
            self.station.update(choice=self.station.manifest["choice"] | {"zoom": zoom})
            await self._report(self.station)
        await self.rig.move_to(point.pan, point.tilt)
        rows, cols = ap.mosaic
        advice = (
            f"; {2 * point.radius_deg:.2f}° across, it will span {fit['target_deg']:.1f}°: "
            f"a {rows}×{cols} mosaic"
            + (
                f" (at {fit['suggested_m']:g} m it would fill a third of the view)"
                if fit.get("suggested_m")
                else ""
            )
            if point.radius_deg
            else ""
        )
        return (
            f"target {point.rank} chosen; next station at {self.distance:g} m aimed at "
            f"pan {point.pan:.2f}, tilt {point.tilt:.2f}{advice}"
        )

    def _fit(self, point: InterestPoint, ratio: float) -> tuple[tuple[int, int], dict[str, Any]]:
        """The next station's mosaic from the target's size: three target diameters each
        way (the target and its setting), at most the configured mosaic; and the distance
        at which it would fill a third of the widest view (the seed's missing foresight
        in where to stand)."""
        c = self.cfg
        if not point.radius_deg:
            return (c.rows, c.cols), {"rows": c.rows, "cols": c.cols}
        camera = self.live_camera()  # at the next leg: narrower if the approach zooms
        across = 2 * point.radius_deg * ratio  # degrees as seen from the next station
        if self._magnification() > 1.0:  # zooming: the view narrows, the target does not grow
            across = 2 * point.radius_deg
        cols = max(1, min(c.cols, math.ceil(3 * across / camera.hfov)))
        rows = max(1, min(c.rows, math.ceil(3 * across / camera.vfov)))
        here = self.cfg.approach[self._approach.leg - 1]
        suggested = round(here * 2 * point.radius_deg / (self.hfov / 3), 1)
        fit = {"rows": rows, "cols": cols, "target_deg": round(across, 3), "suggested_m": suggested}
        return (rows, cols), fit

    async def _report(self, station: Station) -> None:
        """Rewrite the session's report (daemon.report); a report that cannot be written
        (a full disk) is logged and costs the station nothing."""
        try:
            await asyncio.to_thread(write_report, station.folder.parent)
        except (OSError, ValueError, cv2.error) as exc:
            _LOGGER.warning("session report for %s not written: %s", station.name, exc)

    # -- the station -------------------------------------------------------------------

    def _progress(
        self, stage: str, done: int = 0, total: int = 0, eta: float | None = None
    ) -> None:
        self.tel.progress(SurveyProgress(self.station_id, stage, done, total, eta))

    async def _run(self, geometry: MosaicGeometry, profile: str, settings: tuple[str, ...]) -> None:
        station = self.station
        assert station is not None
        t0 = time.perf_counter()
        timing: dict[str, float] = {"predicted_motion_s": 0.0, "grab_s": 0.0}
        try:
            mosaic = await self._acquire(station, geometry, timing)
            await self._register(station, geometry, mosaic)
            ta = time.perf_counter()
            prior = await asyncio.to_thread(self._prior, station, geometry, mosaic)
            # No await between announcing the analysis and handing it to the worker: a worker
            # that dies after the announcement dies with this station's job in it.
            self._progress("analysis", 0, 1)
            doc = await self.worker.call(
                ANALYSE,
                str(station.partial_dir),
                mosaic,
                profile,
                "mosaic.png",
                prior,
                settings,
            )
            timing["analysis_s"] = self._analysis_estimate = time.perf_counter() - ta
            station.publish_analysis()
            points = await asyncio.to_thread(self._recall, self._points(doc, geometry), doc, mosaic)
            station.update(points=[p.to_body() for p in points], products=doc["products"])
            await self._chips(station, points, timing)
            timing["wall_s"] = time.perf_counter() - t0
            station.update(timing=timing)
            station.finish("complete")
            await asyncio.to_thread(self.memory.remember, station.name, mosaic)
            await self._report(station)  # current by the time anyone hears of the result
            self._result = InterestResult(self.station_id, tuple(points), *geometry.size)
            self.state = SurveyState.AWAITING_CHOICE
            self._progress("done", 1, 1, 0.0)
            self.tel.result(self._result)
            self.tel.event(
                "info", f"station {self.station_id} complete: {len(points)} interest points"
            )
        except asyncio.CancelledError as exc:
            reason = str(exc.args[0]) if exc.args else "cancelled"
            await self._abandon(station, "incomplete", reason, timing, t0)
            raise
        except (PtuError, CameraError, WorkerError, OSError, ValueError, TimeoutError) as exc:
            text = _describe(exc)
            await self._abandon(station, "failed", text, timing, t0)
            self.tel.event("error", f"station {self.station_id} failed: {text}")
        except Exception as exc:  # a bug: fail the station, keep the daemon
            _LOGGER.exception("station %s", self.station_id)
            await self._abandon(station, "failed", f"internal error: {exc!r}", timing, t0)
            self.tel.event("error", f"station {self.station_id} failed: internal error {exc!r}")

    async def _abandon(
        self, station: Station, status: str, reason: str, timing: dict[str, float], t0: float
    ) -> None:
        self.state, self.last_error = SurveyState.IDLE, reason if status == "failed" else ""
        with contextlib.suppress(PtuError, OSError, TimeoutError):
            await asyncio.shield(self.rig.ptu.halt())
        timing["wall_s"] = time.perf_counter() - t0
        try:
            station.update(timing=timing)
            station.finish(status, reason)
        except OSError as exc:
            _LOGGER.error("station %s: cannot update the manifest: %s", station.name, exc)
        await asyncio.shield(self._report(station))
        self._progress(status, 0, 0, None)

    async def _settle_and_grab(self, timing: dict[str, float]) -> tuple[PtuPosition, Frame]:
        """Wait for the head to stop (and the tripod to settle), then take a frame."""
        position = await self.rig.settle()
        if self.cfg.settle:
            await asyncio.sleep(self.cfg.settle)
        tg = time.perf_counter()
        frame = await self.rig.grab()
        timing["grab_s"] += time.perf_counter() - tg
        return position, frame

    async def _acquire(
        self, station: Station, geometry: MosaicGeometry, timing: dict[str, float]
    ) -> np.ndarray:
        width, height = geometry.size
        tw, th = geometry.tile_size
        mosaic = np.zeros((height, width, 3), np.uint8)
        order = geometry.serpentine()
        ptu = self.rig.ptu
        place = functools.partial(self._place, station, mosaic, (tw, th))
        pending: tuple[int, int, Frame, tuple[float, float]] | None = None
        t0 = time.perf_counter()
        try:
            for k, (row, col) in enumerate(order):
                pan, tilt = geometry.tile_pose(row, col)
                timing["predicted_motion_s"] += ptu.predict_move_time(pan, tilt)
                await ptu.move_to(pan, tilt, wait=False)
                self.rig.mark_moving()
                if pending is not None:  # reduce, place and archive the last tile while moving
                    job, pending = pending, None
                    await asyncio.to_thread(place, job)
                position, frame = await self._settle_and_grab(timing)
                pending = (row, col, frame, (position.pan, position.tilt))
                per_tile = (time.perf_counter() - t0) / (k + 1)
                eta = per_tile * (len(order) - k - 1 + CHIPS) + self._analysis_estimate
                self._progress("tiles", k + 1, len(order), round(eta, 1))
        except asyncio.CancelledError:
            if pending is not None:  # a frame already taken is kept
                place(pending)
            raise
        if pending is not None:
            await asyncio.to_thread(place, pending)
        await asyncio.to_thread(station.write_png, "mosaic.png", mosaic)
        return mosaic

    @staticmethod
    def _place(
        station: Station,
        mosaic: np.ndarray,
        tile: tuple[int, int],
        pending: tuple[int, int, Frame, tuple[float, float]],
    ) -> None:
        row, col, frame, (pan, tilt) = pending
        tw, th = tile
        image = frame.image
        small = cv2.resize(image, (tw, th), interpolation=cv2.INTER_AREA)
        mosaic[row * th : (row + 1) * th, col * tw : (col + 1) * tw] = small
        station.add_tile(row, col, image, (pan, tilt), frame.timestamp)

    def _points(self, doc: dict[str, Any], geometry: MosaicGeometry) -> list[InterestPoint]:
        points = []
        degrees_per_pixel = geometry.camera.hfov / geometry.tile_size[0]
        for p in doc["points"]:
            # result.json: pixel k's centre is at k; the geometry puts it at k + 0.5.
            pan, tilt = geometry.to_angles(p["x"] + 0.5, p["y"] + 0.5)
            points.append(
                InterestPoint(
                    p["rank"],
                    p["x"],
                    p["y"],
                    p["score"],
                    round(pan, 4),
                    round(tilt, 4),
                    p["description"],
                    self.orientation.azimuth(pan),
                    self.orientation.elevation(tilt),
                    round(p.get("radius", 0.0) * degrees_per_pixel, 4),
                )
            )
        return points

    async def _register(
        self, station: Station, geometry: MosaicGeometry, mosaic: np.ndarray
    ) -> None:
        """Register the station to the one it was aimed from (daemon.register); the
        record, residual included, goes in its manifest. A failure is noted, not raised."""
        ap = self._approach
        if ap.aim is None or not ap.aimed_from:
            return
        previous = ap.aimed_from.split("#")[0]
        session, _, name = previous.partition("/")
        walk = 1.0 if self._magnification() > 1.0 else self.cfg.approach[ap.leg - 1] / self.distance
        try:
            old_geo = self.geometry_of(previous)
            png = self.archive.read(session, f"{name}/mosaic.png", 1 << 26)
            old = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
            if old is None:
                raise ArchiveError(f"{previous}: unreadable mosaic")
            record = await asyncio.to_thread(
                functools.partial(register, target=ap.aim, walk=walk),
                old,
                old_geo,
                mosaic,
                geometry,
            )
        except (ArchiveError, cv2.error, ValueError) as exc:
            record = {"note": f"not registered: {exc}"}
        station.update(registration={"from": previous, **record})

    def _prior(
        self, station: Station, geometry: MosaicGeometry, mosaic: np.ndarray
    ) -> np.ndarray | None:
        """Memory across stations (``survey.memory``): the weights the station it was aimed
        from puts on this one's interest (daemon.memory.station_prior), noted in the
        manifest; None for a first station, with the option off, or when the earlier
        interest cannot be read (noted too)."""
        ap, weight = self._approach, self.cfg.memory
        if weight <= 0 or ap.aim is None or not ap.aimed_from:
            return None
        previous = ap.aimed_from.split("#")[0]
        session, _, name = previous.partition("/")
        walk = 1.0 if self._magnification() > 1.0 else self.cfg.approach[ap.leg - 1] / self.distance
        try:
            png = self.archive.read(session, f"{name}/analysis/interest.png", 1 << 26)
            interest = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_GRAYSCALE)
            if interest is None:
                raise ArchiveError(f"{previous}: unreadable interest map")
            prior = station_prior(
                interest,
                self.geometry_of(previous),
                geometry,
                target=ap.aim,
                radius_deg=ap.radius_deg,
                walk=walk,
                weight=weight,
                mosaic=mosaic,
                palettes=self.memory.palettes(),
            )
        except (ArchiveError, cv2.error, ValueError) as exc:
            station.update(memory={"from": previous, "note": f"no prior: {exc}"})
            return None
        station.update(memory={"from": previous, "weight": weight})
        return prior

    def _recall(
        self, points: list[InterestPoint], doc: dict[str, Any], mosaic: np.ndarray
    ) -> list[InterestPoint]:
        """Each point against what the session's earlier stations showed: its novelty, and
        a clause for its explanation ("new since st01-300m" or "seen at st02-60m")."""
        if not self.memory.stations:
            return points
        first = self.memory.stations[0][0]
        radii = {p["rank"]: p.get("radius", 4.0) for p in doc["points"]}
        out = []
        for p in points:
            found = self.memory.novelty(mosaic, p.x, p.y, radii.get(p.rank, 4.0))
            why = "; ".join(part for part in (p.why, phrase(found, first)) if part)
            out.append(replace(p, why=why, novelty=round(found[0], 2) if found else None))
        return out

    async def _chips(
        self, station: Station, points: list[InterestPoint], timing: dict[str, float]
    ) -> None:
        """Re-point at each interest point and take a full-resolution frame; each chip is
        saved and published while the head already moves to the next one."""
        ptu = self.rig.ptu
        chosen = points[:CHIPS]
        saving: asyncio.Task[Chip] | None = None
        for k, point in enumerate(chosen):
            self._progress("chips", k, len(chosen))
            timing["predicted_motion_s"] += ptu.predict_move_time(point.pan, point.tilt)
            await ptu.move_to(point.pan, point.tilt, wait=False)
            self.rig.mark_moving()
            if saving is not None:
                self.tel.chip(await saving)
            position, frame = await self._settle_and_grab(timing)
            saving = asyncio.create_task(
                asyncio.to_thread(
                    self._save_chip, station, point, (position.pan, position.tilt), frame
                ),
                name="cyborgd.survey.save-chip",
            )
        if saving is not None:
            self.tel.chip(await saving)
        self._progress("chips", len(chosen), len(chosen))

    def _save_chip(
        self, station: Station, point: InterestPoint, pose: tuple[float, float], frame: Frame
    ) -> Chip:
        rel = station.add_chip(point.rank, frame.image, pose, frame.timestamp)
        return Chip(self.station_id, point.rank, *pose, rel, encode_image(frame.image, quality=85))


def _describe(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.filename:
        return f"archive: cannot write {exc.filename}: {exc.strerror or exc}"
    if isinstance(exc, TimeoutError):
        return "the PTU did not reach its target in time"
    return str(exc) or type(exc).__name__
