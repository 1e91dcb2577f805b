"""Where the rig stands and which way it looks: the site, the head's heading, a GPS fix.

Pan and tilt are the PTU's own angles, zero wherever the tripod happened to face. With
``heading`` (the true azimuth of pan 0, clockwise from north) and ``level`` (the elevation
of tilt 0) every interest point gets an azimuth and an elevation anyone can find again
next season with a compass and a clinometer. The position comes from gpsd when one runs
(its JSON protocol over TCP: ``?WATCH`` then ``TPV`` reports, read here in a few lines
rather than pulling in the ``gps`` client library); without a fix, the session's first
station stands at the configured site and each later one where the walk took it
(:func:`place`). A point's target lies along its azimuth and elevation at the station's
distance to the outcrop (:func:`locate`), an estimate: the camera gives a direction, the
approach a range.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import math
import time
from dataclasses import dataclass
from typing import Any

__all__ = ["Gpsd", "Leg", "Orientation", "SiteConfig", "locate", "offset", "place", "where"]

_LOGGER = logging.getLogger(__name__)

FRESH_S = 10.0
"""A fix older than this no longer says where the rig is (the scientist has walked)."""
EARTH_RADIUS_M = 6_371_008.8
"""The mean radius of the WGS84 ellipsoid (IUGG), for the sphere :func:`offset` walks on."""
_FALLBACKS = ("config", "unknown")
"""Sources of a site record that are not a fix: a later station is better dead-reckoned."""


@dataclass(frozen=True)
class SiteConfig:
    name: str = ""
    """Free text: the outcrop, the locality."""
    latitude: float | None = None
    longitude: float | None = None
    altitude: float | None = None
    """Metres above the WGS84 ellipsoid (gpsd's altHAE) or as surveyed."""
    heading: float | None = None
    """True azimuth of pan 0, degrees clockwise from north (a compass sighting along the
    camera at pan 0, corrected for declination); unknown: azimuths are not reported."""
    level: float = 0.0
    """Elevation of tilt 0, degrees (the tripod head's spirit level's error)."""
    gpsd: str = ""
    """host:port of a gpsd whose fixes override latitude, longitude and altitude."""


@dataclass(frozen=True)
class Orientation:
    """The head's angles to the world's."""

    heading: float | None
    level: float = 0.0

    def azimuth(self, pan: float) -> float | None:
        """Pan turns right, as a compass does.

        >>> Orientation(350.0).azimuth(15.0), Orientation(None).azimuth(15.0)
        (5.0, None)
        """
        return None if self.heading is None else round((self.heading + pan) % 360.0, 3)

    def elevation(self, tilt: float) -> float:
        return round(tilt + self.level, 3)


class Gpsd:
    """The latest fix from a gpsd, kept current by :meth:`run` (reconnects forever)."""

    def __init__(self, endpoint: str) -> None:
        host, _, port = endpoint.rpartition(":")
        self.host, self.port = host or "127.0.0.1", int(port or 2947)
        self.fix: dict[str, Any] | None = None
        self.received_at = 0.0

    def position(self) -> dict[str, Any] | None:
        """The last fix if it is fresh: lat, lon, alt (if 3D), time, mode, source."""
        if self.fix is None or time.monotonic() - self.received_at > FRESH_S:
            return None
        return self.fix

    async def run(self) -> None:
        delay = 1.0
        while True:
            try:
                reader, writer = await asyncio.open_connection(self.host, self.port)
            except OSError as exc:
                _LOGGER.debug("gpsd %s:%d: %s", self.host, self.port, exc)
                await asyncio.sleep(delay)
                delay = min(30.0, delay * 2)
                continue
            delay = 1.0
            try:
                writer.write(b'?WATCH={"enable":true,"json":true};\n')
                await writer.drain()
                while line := await reader.readline():
                    self._report(line)
            except OSError as exc:
                _LOGGER.warning("gpsd %s:%d: %s", self.host, self.port, exc)
            finally:
                writer.close()
                with contextlib.suppress(OSError):
                    await writer.wait_closed()
            await asyncio.sleep(delay)

    def _report(self, line: bytes) -> None:
        try:
            doc = json.loads(line)
        except ValueError:
            return  # gpsd speaks JSON; anything else is noise on the socket
        if not isinstance(doc, dict) or doc.get("class") != "TPV":
            return
        mode, lat, lon = doc.get("mode", 0), doc.get("lat"), doc.get("lon")
        if not isinstance(mode, int) or mode < 2 or not _number(lat) or not _number(lon):
            return  # no fix yet
        alt = doc.get("altHAE", doc.get("alt"))
        self.fix = {
            "latitude": float(lat),
            "longitude": float(lon),
            "altitude": float(alt) if mode >= 3 and _number(alt) else None,
            "time": str(doc.get("time", "")),
            "mode": mode,
            "source": f"gpsd {self.host}:{self.port}",
        }
        self.received_at = time.monotonic()


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def where(site: SiteConfig, gpsd: Gpsd | None) -> dict[str, Any]:
    """The station's site record for its manifest: a fresh GPS fix, else the config."""
    record: dict[str, Any] = {"name": site.name, "heading": site.heading, "level": site.level}
    fix = gpsd.position() if gpsd is not None else None
    if fix is not None:
        return record | fix
    return record | {
        "latitude": site.latitude,
        "longitude": site.longitude,
        "altitude": site.altitude,
        "source": "config" if site.latitude is not None else "unknown",
    }


@dataclass(frozen=True)
class Leg:
    """How the rig came to a station from an earlier one."""

    start: str
    """The earlier station's name."""
    bearing: float | None
    """True azimuth walked (the chosen target's at the earlier station); None: no heading."""
    distance: float
    """Metres walked; 0 when the rig stayed (the lens zoomed, or no target was chosen)."""


def offset(
    latitude: float, longitude: float, bearing: float, distance: float
) -> tuple[float, float]:
    """The place ``distance`` metres from (latitude, longitude) along ``bearing`` (degrees
    true), by the great-circle direct formula on a sphere.

    Hand-written rather than a geodesy library's ellipsoidal solution: over a leg of a few
    hundred metres the sphere is off by under 0.5 %, far below a paced walk's error.

    >>> offset(40.0, -3.0, 0.0, 1000.0)  # 1 km north: 1/6371.0088 rad of latitude
    (40.0089932, -3.0)
    """
    lat, lon, brg = map(math.radians, (latitude, longitude, bearing))
    d = distance / EARTH_RADIUS_M
    lat2 = math.asin(math.sin(lat) * math.cos(d) + math.cos(lat) * math.sin(d) * math.cos(brg))
    lon2 = lon + math.atan2(
        math.sin(brg) * math.sin(d) * math.cos(lat), math.cos(d) - math.sin(lat) * math.sin(lat2)
    )
    return round(math.degrees(lat2), 7), round((math.degrees(lon2) + 540.0) % 360.0 - 180.0, 7)


def place(here: dict[str, Any], earlier: dict[str, Any] | None, leg: Leg | None) -> dict[str, Any]:
    """A station's site record: ``here`` (:func:`where`) when it is a fix or the session's
    first station; else the ``earlier`` station's site record moved along ``leg``.

    A station that did not move stands where the earlier one stood, known the same way. A
    walked one is dead-reckoned (its altitude unknown: the climb is not measured), or
    unknown when the earlier position or the bearing is.
    """
    if here.get("source") not in _FALLBACKS or earlier is None or leg is None:
        return here
    if not leg.distance:
        keys = ("latitude", "longitude", "altitude", "source", "leg")
        return here | {k: earlier[k] for k in keys if k in earlier}
    lat, lon = earlier.get("latitude"), earlier.get("longitude")
    if lat is None or lon is None or leg.bearing is None:
        return here | {"latitude": None, "longitude": None, "altitude": None, "source": "unknown"}
    lat, lon = offset(lat, lon, leg.bearing, leg.distance)
    walked = {"from": leg.start, "bearing_deg": leg.bearing, "distance_m": leg.distance}
    return here | {
        "latitude": lat,
        "longitude": lon,
        "altitude": None,
        "source": "dead-reckoned",
        "leg": walked,
    }


def locate(
    points: list[dict[str, Any]], site: dict[str, Any], range_m: float
) -> list[dict[str, Any]]:
    """``points`` (manifest dicts), each with its target's ``position`` where one is known:
    ``range_m`` along its azimuth and elevation from the station, which needs the station's
    position and the azimuth. An estimate: the range is the station's distance to the
    outcrop, not measured to the point.

    >>> site = {"latitude": 40.0, "longitude": -3.0, "altitude": 600.0}
    >>> north, aimless = locate([{"azimuth": 0.0, "elevation": 30.0}, {}], site, 2000.0)
    >>> to = north["position"]  # 1732 m north, 1000 m up
    >>> to["latitude"], to["longitude"], to["altitude"], to["estimated"], "position" in aimless
    (40.0155767, -3.0, 1600.0, True, False)
    """
    lat, lon, alt = site.get("latitude"), site.get("longitude"), site.get("altitude")
    if lat is None or lon is None or not range_m:
        return points
    located = []
    for point in points:
        if point.get("azimuth") is None:
            located.append(point)
            continue
        elevation = math.radians(point.get("elevation") or 0.0)
        to = offset(lat, lon, point["azimuth"], range_m * math.cos(elevation))
        position = {
            "latitude": to[0],
            "longitude": to[1],
            "altitude": None if alt is None else round(alt + range_m * math.sin(elevation), 2),
            "range_m": range_m,
            "estimated": True,
        }
        located.append(point | {"position": position})
    return located
