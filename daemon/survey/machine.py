"""The survey state machine: plan, acquire, analyse, chips, choose, next station.

One station: shoot an M×N mosaic, butted or registered (``acquire``); register it to the
station it was aimed from (``register``) and weigh it by what that one found (``memory``);
hand it to the vision worker (a registered mosaic's seams are cut again off what the science
found and the mosaic looked at again, ``stitch``); re-point at the top three interest points
for full-resolution chips while the worker draws and writes the analysis's products; publish
the result and wait for the operator's choice. Choosing a target aims the next station at
it, one step closer along the approach (``approach``).
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import functools
import logging
import time
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass
from enum import StrEnum
from typing import TYPE_CHECKING, Any

import numpy as np

from cyborg.protocol.messages import Chip, ChooseTarget, InterestResult, SurveyProgress, SurveyStart

from ..archive import Archive, Station
from ..camera import CameraError
from ..pointing.geometry import CameraModel, MosaicGeometry
from ..ptu import PtuError
from ..rig import Rig
from ..vision.contract import Analysed, AnalysisResult, PointsJob, ProductsJob
from ..worker import VisionWorker, WorkerError
from .acquire import CHIPS, Acquisition, check_reach
from .analysis import check_profile, interest_points
from .approach import Approach, advice
from .memory import SessionMemory
from .register import register_to
from .report import update_report
from .site import Orientation, locate
from .stitch import KEEP_OFF_ROUNDS, Stitcher, no_data

if TYPE_CHECKING:  # config imports the survey package (its site)
    from ..config import SurveyConfig

__all__ = ["Survey", "SurveyBusyError", "SurveyState", "SurveyTelemetry"]

_LOGGER = logging.getLogger(__name__)


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


class Survey:
    """The survey engine: one station at a time, then the operator's choice (module doc)."""

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
        rig stands when a station starts (survey.site.where)."""
        self.rig, self.worker, self.archive, self.cfg = rig, worker, archive, config
        self.hfov = hfov
        self.tel = telemetry
        self.orientation = orientation or Orientation(None)
        self.site = site or (lambda: {})
        self.state: SurveyState = SurveyState.IDLE
        self.station: Station | None = None
        self.last_error = ""
        self._task: asyncio.Task[None] | None = None
        self._drawings: set[asyncio.Task[None]] = set()
        self._approach = Approach()
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
        return self._approach.distance(self.cfg)

    @property
    def aim(self) -> str:
        """The aim of study a station started without one takes (``Approach.aim_of_study``)."""
        return self._approach.aim_of_study(self.cfg)

    @property
    def station_id(self) -> str:
        return f"{self._approach.session}/{self.station.name}" if self.station else ""

    def start(self, req: SurveyStart, requested_by: str) -> str:
        """Plan and launch a station; returns its id. Raises before touching anything if
        the plan leaves the unit's limits or what the camera shows, or a survey runs."""
        if self.running:
            raise SurveyBusyError(f"station {self.station_id} is still running")
        cfg, ap = self.cfg, self._approach
        req = ap.complete(req, cfg)
        check_profile(req.profile, req.settings or ())
        centre = self._last_centre or (cfg.pan0, cfg.tilt0)
        geometry = ap.plan(req, centre, self.live_camera(), cfg.overlap)
        check_reach(geometry, self.rig.ptu.info)
        geometry.check_within(self.rig.camera.extent)
        self._last_centre = (geometry.pan0, geometry.tilt0)
        last = self.station_id if ap.session else ""  # the session's last station
        if not ap.session:
            ap.session, ap.index = self.archive.new_session(), 0
            self.memory.clear()
        ap.index += 1
        ap.sought = aim = req.aim  # completed: asked for, kept, or configured
        settings = tuple(req.settings or ())
        self.station = self.archive.new_station(
            ap.session,
            ap.index,
            self.distance,
            plan=geometry.to_plan(profile=req.profile, settings=list(settings), aim=aim),
            site=ap.place(cfg, self.archive, self.site(), last),
            requested_by=requested_by,
            aim={"pan": ap.aim[0], "tilt": ap.aim[1], "from": ap.aimed_from} if ap.aim else None,
        )
        self.state, self.last_error, self._result = SurveyState.SURVEYING, "", None
        self._task = asyncio.create_task(
            self._run(geometry, req.profile, settings, aim), name="cyborgd.survey.run"
        )
        return self.station_id

    def live_camera(self) -> CameraModel:
        """The camera's optics as they are now (a simulated approach magnifies them)."""
        return self._approach.camera(self.cfg, self._optics)

    @property
    def _optics(self) -> CameraModel:
        """The camera's optics unzoomed, as at the approach's first station."""
        return CameraModel(*self.rig.camera.resolution, self.hfov)

    async def cancel(self, reason: str) -> bool:
        task = self._task
        if task is None or task.done():
            return False
        task.cancel(reason)
        with contextlib.suppress(asyncio.CancelledError):
            await task
        return True

    async def stop(self, reason: str) -> None:
        """The daemon is stopping: cancel the station, and let products still being drawn
        for an ended one finish (the caller bounds the wait; what is left is cancelled)."""
        await self.cancel(reason)
        try:
            if self._drawings:
                await asyncio.wait(set(self._drawings))
        finally:
            for task in self._drawings:
                task.cancel()

    async def choose(self, msg: ChooseTarget, by: str) -> str:
        """Record the operator's choice; aim the next station at it, one leg closer."""
        result, station = self._result, self.station
        if self.state != SurveyState.AWAITING_CHOICE or result is None or station is None:
            raise ValueError("no station is waiting for a choice")
        if msg.station != result.station:
            raise ValueError(f"station {msg.station!r} is not the one waiting ({result.station})")
        point = next((p for p in result.points if p.rank == msg.rank), None) if msg.rank else None
        if msg.rank and point is None:
            raise ValueError(f"station {result.station} has no point of rank {msg.rank}")
        if point is not None and not point.target:
            raise ValueError(
                f"point {msg.rank} at {result.station} is no further target: its score cannot "
                "be told from the view's background"
            )
        aimed = {"pan": point.pan, "tilt": point.tilt} if point else {}
        station.update(choice={"rank": msg.rank, **aimed, "by": by, "t": time.time()})
        await update_report(station)
        self.state, ap = SurveyState.IDLE, self._approach
        if point is None:
            ap.unaim()
            return f"no target chosen at {result.station}; next station at {self.distance:g} m"
        if ap.last_leg(self.cfg):
            self._approach = Approach()
            await self.rig.move_to(point.pan, point.tilt)
            return f"target {point.rank} chosen at the last station; next survey: new session"
        fit = ap.advance(point, result.station, self.cfg, self._optics)
        station.amend("choice", next=fit)
        zoom = await ap.zoom(self.cfg, self.rig.camera)
        if zoom is not None:
            station.amend("choice", zoom=zoom)
            await update_report(station)
        await self.rig.move_to(point.pan, point.tilt)
        return (
            f"target {point.rank} chosen; next station at {self.distance:g} m aimed at "
            f"pan {point.pan:.2f}, tilt {point.tilt:.2f}{advice(point, fit)}"
        )

    # -- the station -------------------------------------------------------------------

    def _progress(
        self, stage: str, done: int = 0, total: int = 0, eta: float | None = None
    ) -> None:
        self.tel.progress(SurveyProgress(self.station_id, stage, done, total, eta))

    async def _run(
        self, geometry: MosaicGeometry, profile: str, settings: tuple[str, ...], aim: str
    ) -> None:
        """One station (module doc); its aim reaches the analysis as a parameter, so
        result.json's params record it with the rest."""
        station = self.station
        assert station is not None
        t0 = time.perf_counter()
        timing: dict[str, float] = {"predicted_motion_s": 0.0, "grab_s": 0.0}
        shots = Acquisition(self.rig, self.cfg.settle, timing, self._progress)
        previous = self._approach.previous(self.cfg)
        drawing: asyncio.Task[AnalysisResult] | None = None
        later: ProductsJob | None = None  # what the drawing draws, to draw again if stopped
        try:
            mosaic, rest = await shots.tiles(station, geometry, self._analysis_estimate)
            if previous is not None:
                reg = await asyncio.to_thread(register_to, previous, self.archive, mosaic, geometry)
                station.update(registration=reg)
            ta = time.perf_counter()
            prior, memory = await asyncio.to_thread(
                self.memory.prior, previous, self.archive, geometry, mosaic, self.cfg.memory
            )
            if memory is not None:
                station.update(memory=memory)
            async with _alongside(rest):  # the last tile and the mosaic archived meanwhile
                # No await between announcing the analysis and handing it to the worker: a
                # worker that dies after the announcement dies with this station's job in it.
                self._progress("analysis", 0, 1)
                job = PointsJob(
                    str(station.partial_dir),
                    mosaic,
                    profile,
                    "mosaic.png",
                    prior,
                    (*settings, f"aim={aim}"),
                    no_data(mosaic, geometry),
                )
                analysed = await self.worker.call(job)
            if shots.stitcher is not None:
                mosaic, analysed = await self._seams_off(station, shots.stitcher, job, analysed)
            timing["analysis_s"] = self._analysis_estimate = time.perf_counter() - ta
            # The worker draws and writes the products while the head goes to the chips.
            later = analysed.products
            drawing = asyncio.create_task(
                self._products(later, timing), name="cyborgd.survey.products"
            )
            found = interest_points(analysed.result, geometry, self.orientation, mosaic)
            points = await asyncio.to_thread(
                self.memory.recall, found, mosaic, geometry, previous, self.archive
            )
            bodies = [p.to_body() for p in points]
            site, range_m = station.manifest["site"], self._approach.range(self.cfg)
            station.update(points=locate(bodies, site, range_m))
            await shots.chips(station, self.station_id, points, self.tel.chip, (mosaic, geometry))
            analysis = await drawing
            station.publish_analysis()
            station.update(products=analysis.products)
            timing["wall_s"] = time.perf_counter() - t0
            station.update(timing=timing)
            station.finish("complete")
            await asyncio.to_thread(
                self.memory.remember, self.station_id, mosaic, geometry, points, previous
            )
            await update_report(station)  # current by the time anyone hears of the result
            self._result = InterestResult(self.station_id, tuple(points), *geometry.size, aim)
            self.state = SurveyState.AWAITING_CHOICE
            self._progress("done", 1, 1, 0.0)
            self.tel.result(self._result)
            self.tel.event(
                "info",
                f"station {self.station_id} complete: {len(points)} interest points, aim {aim}",
            )
        except asyncio.CancelledError as exc:
            reason = str(exc.args[0]) if exc.args else "cancelled"
            ended = (drawing, later)
            await self._abandon(station, "incomplete", reason, timing, t0, products=ended)
            raise
        except (PtuError, CameraError, WorkerError, OSError, ValueError, TimeoutError) as exc:
            text = _describe(exc)
            await self._abandon(station, "failed", text, timing, t0, products=(drawing, later))
            self.tel.event("error", f"station {self.station_id} failed: {text}")
        except Exception as exc:  # a bug: fail the station, keep the daemon
            _LOGGER.exception("station %s", self.station_id)
            await self._abandon(
                station, "failed", f"internal error: {exc!r}", timing, t0, products=(drawing, later)
            )
            self.tel.event("error", f"station {self.station_id} failed: internal error {exc!r}")

    async def _seams_off(
        self, station: Station, stitcher: Stitcher, job: PointsJob, analysed: Analysed
    ) -> tuple[np.ndarray, Analysed]:
        """Cut a registered mosaic's seams again off the points the science found and look
        again, while a seam passes near one (``Stitcher.keep_off``, at most
        ``KEEP_OFF_ROUNDS`` times): what the scientist will look at is drawn from one frame,
        not blended across a seam. The mosaic archived, analysed and remembered is the last;
        the manifest's ``seams`` says how many times they were cut again."""
        mosaic, rounds, kept = job.image, 0, list[tuple[float, float]]()
        for _ in range(KEEP_OFF_ROUNDS):
            kept = [(p.x, p.y) for p in analysed.result.points[:CHIPS]] + kept  # newest first
            if not await asyncio.to_thread(stitcher.keep_off, kept):
                break
            mosaic = await asyncio.to_thread(stitcher.compose)
            job = dataclasses.replace(job, image=mosaic, no_data=no_data(mosaic, stitcher.geometry))
            async with _alongside(functools.partial(station.write_png, "mosaic.png", mosaic)):
                analysed = await self.worker.call(job)
            rounds += 1
        station.update(seams={"cut_again": rounds})
        return mosaic, analysed

    async def _products(self, job: ProductsJob, timing: dict[str, float]) -> AnalysisResult:
        """Have the worker write an analysis's products; ``products_s`` says how long."""
        tp = time.perf_counter()
        analysis = await self.worker.call(job)
        timing["products_s"] = time.perf_counter() - tp
        return analysis

    async def _abandon(
        self,
        station: Station,
        status: str,
        reason: str,
        timing: dict[str, float],
        t0: float,
        *,
        products: tuple[asyncio.Task[AnalysisResult] | None, ProductsJob | None] = (None, None),
    ) -> None:
        """End a station short, the head halted first. Products the worker already wrote
        are kept, as the points are; a drawing still under way (``products``: its task and
        its job) is stopped (its worker replaced, as a cancelled analysis's) and drawn again
        once the station has ended (:meth:`_draw_again`): nothing the science found is lost
        to a HALT."""
        self.state, self.last_error = SurveyState.IDLE, reason if status == "failed" else ""
        with contextlib.suppress(PtuError, OSError, TimeoutError):
            await asyncio.shield(self.rig.ptu.halt())
        drawing, later = products
        drawn = None if drawing is None else await _finished(drawing)
        timing["wall_s"] = time.perf_counter() - t0
        try:
            if drawn is not None:
                station.publish_analysis()
                station.update(products=drawn.products)
            station.update(timing=timing)
            station.finish(status, reason)
        except OSError as exc:
            _LOGGER.error("station %s: cannot update the manifest: %s", station.name, exc)
        await asyncio.shield(update_report(station))
        self._progress(status, 0, 0, None)
        if drawing is not None and drawn is None and later is not None:
            task = asyncio.create_task(
                self._draw_again(station, self.station_id, later),
                name="cyborgd.survey.products-again",
            )
            self._drawings.add(task)
            task.add_done_callback(self._drawings.discard)

    async def _draw_again(self, station: Station, name: str, job: ProductsJob) -> None:
        """Draw the products of a station that ended while they were drawn, on the worker
        that replaced the stopped one; publish them and write the report again. The next
        station's analysis waits behind it for the worker (about as long as the products
        take); a HALT does not stop it, as it moves nothing."""
        try:
            analysis = await self.worker.call(job)
            station.publish_analysis()
            station.update(products=analysis.products)
        except (WorkerError, OSError) as exc:
            with contextlib.suppress(OSError):
                await asyncio.to_thread(station.discard_partial)
            self.tel.event("warning", f"station {name}: its products could not be drawn: {exc}")
            return
        await update_report(station)
        self.tel.event("info", f"station {name}: its products were drawn after it ended")


@contextlib.asynccontextmanager
async def _alongside(work: Callable[[], None]) -> AsyncIterator[None]:
    """Run ``work`` (archive writes) in a thread while the body runs, and leave only once it
    is done, whatever ends the body: the manifest has one writer at a time. Its error is
    raised if the body's is none."""
    task = asyncio.ensure_future(asyncio.to_thread(work))
    try:
        yield
    finally:
        await asyncio.wait([task])
        error = task.exception()
    if error is not None:
        raise error


async def _finished(task: asyncio.Task[AnalysisResult]) -> AnalysisResult | None:
    """The task's result if it had finished; else it is stopped now (None)."""
    task.cancel()
    await asyncio.wait([task])
    if task.cancelled() or task.exception() is not None:
        return None
    return task.result()


def _describe(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.filename:
        return f"archive: cannot write {exc.filename}: {exc.strerror or exc}"
    if isinstance(exc, TimeoutError):
        return "the PTU did not reach its target in time"
    return str(exc) or type(exc).__name__
