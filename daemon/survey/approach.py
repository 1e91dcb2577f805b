"""The approach between stations: the leg the rig is on (the seed's 300 m -> 60 m -> 10 m),
where the next station is aimed, its mosaic fitted to the aimed target, the zoom a zooming
(or simulated) approach applies, the one look-up of the station it was aimed from, and where
each station stood.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np

from cyborg.protocol.messages import InterestPoint, SurveyStart

from ..archive import Archive, ArchiveError
from ..camera import Camera
from ..pointing.geometry import CameraModel, MosaicGeometry, SphericalMosaic
from .site import Leg, place

if TYPE_CHECKING:  # config imports the survey package (its site)
    from ..config import SurveyConfig

__all__ = ["Approach", "Previous", "advice", "station_geometry", "station_image", "walks", "zooms"]


_LOGGER = logging.getLogger(__name__)


def zooms(cfg: SurveyConfig) -> bool:
    """Whether the approach narrows the lens rather than walks (intelligent zoom, or a
    simulation)."""
    return cfg.simulate_approach or cfg.zoom_on_target


def walks(cfg: SurveyConfig) -> bool:
    """Whether the rig moves between stations. Only an intelligent zoom leaves it on its
    tripod: a simulated approach stands for a walk (the simulated world is seen from ever
    closer along the line of sight, which the narrowing lens renders), so it is placed as one.
    """
    return not cfg.zoom_on_target


def _overlap(profile: str, overlap: float) -> float:
    """The share of a field of view a station of ``profile`` overlaps its frames by,
    ``[survey] overlap`` being ``overlap``: none for ``paper``, the seed's butting its choice."""
    return 0.0 if profile == "paper" else overlap


def station_geometry(archive: Archive, station_id: str) -> MosaicGeometry:
    """How a station's mosaic maps to angles, from its archived plan."""
    try:
        return MosaicGeometry.from_plan(archive.manifest(station_id)["plan"])
    except (ValueError, KeyError, TypeError) as exc:
        raise ArchiveError(f"station {station_id}: no usable plan ({exc})") from None


@dataclass(frozen=True)
class Previous:
    """The station the current one was aimed from, and how the view changed since."""

    station: str
    """Its id, ``session/name``."""
    target: tuple[float, float]
    """The (pan, tilt) chosen there."""
    radius_deg: float
    """The target's angular radius as that station saw it."""
    walk: float
    """How many times closer the rig stands now (1 when the approach zooms)."""

    def geometry(self, archive: Archive) -> MosaicGeometry:
        return station_geometry(archive, self.station)

    def image(self, archive: Archive, product: str, flags: int, what: str) -> np.ndarray:
        """One of its images (``mosaic.png``, ``analysis/interest.png``), decoded."""
        return station_image(archive, self.station, product, flags, what)


def station_image(
    archive: Archive, station_id: str, product: str, flags: int, what: str
) -> np.ndarray:
    """One of a station's archived images (``mosaic.png``, ...), decoded as ``flags`` ask."""
    session, _, name = station_id.partition("/")
    png = archive.read(session, f"{name}/{product}", 1 << 26)
    image = cv2.imdecode(np.frombuffer(png, np.uint8), flags)
    if image is None:
        raise ArchiveError(f"{station_id}: unreadable {what}")
    return image


@dataclass
class Approach:
    """Where the approach loop stands between stations."""

    session: str = ""
    index: int = 0
    leg: int = 0
    aim: tuple[float, float] | None = None
    aimed_from: str = ""
    """``session/name#rank``: the station and point the aim was chosen at."""
    radius_deg: float = 0.0
    """The aimed target's angular radius, as the station it was chosen at saw it."""
    bearing: float | None = None
    """The aimed target's azimuth at the station it was chosen at: the way the rig walks."""
    mosaic: tuple[int, int] | None = None
    """(rows, cols) fields of view fitted to the aimed target's size: as many butted frames,
    more overlapping ones (:meth:`complete`)."""
    sought: str = ""
    """The aim of study (``protocol.aims``) the session's last station asked for."""
    spans: tuple[int | None, int | None] = (None, None)
    """(pan, tilt) fields of view the last completed request's tiles are stretched across:
    an unaimed station's configured cols and rows, exactly as butted; None on an axis asked
    for, and for an aimed station, whose tiles step ``1 - overlap`` and so span a little more
    than its fitted fields (as measured on ``bench.approach``) (:meth:`complete`)."""

    def distance(self, cfg: SurveyConfig) -> float:
        return cfg.approach[self.leg]

    def range(self, cfg: SurveyConfig) -> float:
        """This leg's station's distance to the outcrop from where it stands (a zooming
        approach stays at the first leg's)."""
        return self.distance(cfg) if walks(cfg) else cfg.approach[0]

    def place(
        self, cfg: SurveyConfig, archive: Archive, here: dict[str, Any], last: str
    ) -> dict[str, Any]:
        """This leg's station's site record (``site.place``): ``here`` (a fix, or the site)
        for a session's first station; else dead-reckoned from the station it was aimed
        from, along the chosen target's azimuth by the distance walked; an unaimed station
        stands where ``last`` (the session's last station, ``session/name``) stood."""
        start = self.aimed_from.split("#")[0] or last
        if not start:
            return here
        try:
            earlier = archive.manifest(start)
        except (ArchiveError, OSError, ValueError) as exc:
            _LOGGER.warning("station %s: where it stood is unknown: %s", start, exc)
            earlier = {}
        walked = 0.0
        if self.aimed_from and walks(cfg) and "distance_m" in earlier:
            walked = round(float(earlier["distance_m"]) - self.distance(cfg), 3)
        leg = Leg(start.rpartition("/")[2], self.bearing if self.aimed_from else None, walked)
        return place(here, earlier.get("site") or {}, leg)

    def last_leg(self, cfg: SurveyConfig) -> bool:
        return self.leg + 1 >= len(cfg.approach)

    def magnification(self, cfg: SurveyConfig) -> float:
        """How much closer the approach has brought the view, when it zooms rather than
        walks."""
        return cfg.approach[0] / self.distance(cfg) if zooms(cfg) else 1.0

    def camera(self, cfg: SurveyConfig, base: CameraModel) -> CameraModel:
        """The optics of ``base`` as this leg sees through them."""
        return base.zoomed(self.magnification(cfg))

    def aim_of_study(self, cfg: SurveyConfig) -> str:
        """The aim a station started without one takes: the session's last station's (an
        approach keeps what it is after), else the configured one."""
        return self.sought or cfg.aim

    def complete(self, req: SurveyStart, cfg: SurveyConfig) -> SurveyStart:
        """``req`` with what it leaves open filled in: the tiles that span the fields of view
        of the mosaic fitted to the aimed target, else of the configured one, overlapping as
        the station will (:meth:`SphericalMosaic.tiles`; :attr:`spans`);
        the configured reduction, profile and settings; the aim of study
        (:meth:`aim_of_study`). Rows or cols asked for are the tiles shot."""
        profile = cfg.profile if req.profile is None else req.profile
        rows, cols = self.mosaic or (cfg.rows, cfg.cols)
        spanned = self.mosaic is None
        self.spans = (
            cols if spanned and req.cols is None else None,
            rows if spanned and req.rows is None else None,
        )
        rows, cols = _tiles((rows, cols), _overlap(profile, cfg.overlap))
        return replace(
            req,
            rows=rows if req.rows is None else req.rows,
            cols=cols if req.cols is None else req.cols,
            downsample=cfg.downsample if req.downsample is None else req.downsample,
            profile=profile,
            settings=cfg.settings if req.settings is None else req.settings,
            aim=self.aim_of_study(cfg) if req.aim is None else req.aim,
        )

    def plan(
        self,
        req: SurveyStart,
        centre: tuple[float, float],
        camera: CameraModel,
        overlap: float = 0.0,
    ) -> MosaicGeometry:
        """The mosaic a completed ``req`` shoots through ``camera``, its frames overlapping
        by ``overlap`` (:func:`_overlap`) and stretched across the fields of view they
        stand for (:attr:`spans`). Its centre is always a decision: asked for, aimed at,
        else ``centre`` (surveyed before, or set up)."""
        default = self.aim or centre
        pan0 = req.pan0 if req.pan0 is not None else default[0]
        tilt0 = req.tilt0 if req.tilt0 is not None else default[1]
        butted = MosaicGeometry(camera, req.rows, req.cols, pan0, tilt0, req.downsample)
        return butted.overlapping(_overlap(req.profile, overlap), spans=self.spans)

    def previous(self, cfg: SurveyConfig) -> Previous | None:
        """The station this leg was aimed from; None for a first station or an unaimed one."""
        if self.aim is None or not self.aimed_from:
            return None
        here = self.distance(cfg)
        walk = 1.0 if self.magnification(cfg) > 1.0 else cfg.approach[self.leg - 1] / here
        return Previous(self.aimed_from.split("#")[0], self.aim, self.radius_deg, walk)

    def unaim(self) -> None:
        """No target chosen: the next station is shot at this leg, where the last one was."""
        self.aim, self.aimed_from, self.mosaic, self.bearing = None, "", None, None

    def advance(
        self, point: InterestPoint, chosen_at: str, cfg: SurveyConfig, base: CameraModel
    ) -> dict[str, Any]:
        """Aim the next leg at ``point``, chosen at station ``chosen_at``, its mosaic fitted
        to the target; returns the fit for the manifest."""
        ratio = self.distance(cfg) / cfg.approach[self.leg + 1]
        self.leg += 1
        self.aim, self.aimed_from = (point.pan, point.tilt), f"{chosen_at}#{point.rank}"
        self.radius_deg, self.bearing = point.radius_deg or 0.0, point.azimuth
        self.mosaic, fit = self._fit(point, ratio, cfg, base)
        return fit

    def _fit(
        self, point: InterestPoint, ratio: float, cfg: SurveyConfig, base: CameraModel
    ) -> tuple[tuple[int, int], dict[str, Any]]:
        """The next station's mosaic from the target's size: three target diameters each
        way (the target and its setting), in fields of view, at most the configured mosaic's
        (an overlapping station shoots more tiles to span them, ``tiles``: :meth:`complete`);
        and the distance at which it would fill a third of the widest view (the seed's
        missing foresight in where to stand)."""
        overlap = _overlap(cfg.profile, cfg.overlap)
        if not point.radius_deg:
            fields = (cfg.rows, cfg.cols)
            return fields, {"rows": cfg.rows, "cols": cfg.cols, "tiles": _tiles(fields, overlap)}
        camera = self.camera(cfg, base)  # at the next leg: narrower if the approach zooms
        across = 2 * point.radius_deg * ratio  # degrees as seen from the next station
        if self.magnification(cfg) > 1.0:  # zooming: the view narrows, the target does not grow
            across = 2 * point.radius_deg
        cols = max(1, min(cfg.cols, math.ceil(3 * across / camera.hfov)))
        rows = max(1, min(cfg.rows, math.ceil(3 * across / camera.vfov)))
        here = cfg.approach[self.leg - 1]
        suggested = round(here * 2 * point.radius_deg / (base.hfov / 3), 1)
        fit = {
            "rows": rows,
            "cols": cols,
            "tiles": _tiles((rows, cols), overlap),
            "target_deg": round(across, 3),
            "suggested_m": suggested,
        }
        return (rows, cols), fit

    async def zoom(self, cfg: SurveyConfig, camera: Camera) -> dict[str, float] | None:
        """Zoom ``camera`` to this leg's magnification if the approach zooms; the record."""
        if not zooms(cfg):
            return None
        level = self.magnification(cfg)
        seconds = await camera.zoom(level)
        return {"level": round(level, 4), "seconds": round(seconds, 3)}


def _tiles(fields: tuple[int, int], overlap: float) -> tuple[int, int]:
    """(rows, cols) of tiles overlapping by ``overlap`` that span ``fields`` (rows, cols)
    fields of view (:meth:`SphericalMosaic.tiles`); as many as fields when butted."""
    rows, cols = (SphericalMosaic.tiles(n, overlap) for n in fields)
    return rows, cols


def advice(point: InterestPoint, fit: dict[str, Any]) -> str:
    """What the operator hears about the next station's mosaic, for a target with a size:
    the tiles its plan will shoot (``tiles``, as the manifest's plan will record them)."""
    if not point.radius_deg:
        return ""
    where = (
        f" (at {fit['suggested_m']:g} m it would fill a third of the view)"
        if fit.get("suggested_m")
        else ""
    )
    (rows, cols), fields = fit["tiles"], (fit["rows"], fit["cols"])
    shot = f"a {rows}×{cols} mosaic"
    if (rows, cols) != fields:
        shot += f" of overlapping frames across {fields[0]}×{fields[1]} fields of view"
    across = f"{2 * point.radius_deg:.2f}° across, it will span {fit['target_deg']:.1f}°"
    return f"; {across}: {shot}{where}"
