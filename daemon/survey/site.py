"""Where the rig stands and which way it looks: the site, the head's heading, a GPS fix.

Pan and tilt are the PTU's own angles, zero wherever the tripod happened to face. With
``heading`` (the true azimuth of pan 0, clockwise from north) and ``level`` (the elevation
of tilt 0) every interest point gets an azimuth and an elevation anyone can find again
next season with a compass and a clinometer. The position comes from gpsd when one runs
(its JSON protocol over TCP: ``?WATCH`` then ``TPV`` reports, read here in a few lines
rather than pulling in the ``gps`` client library), else from the configured site.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import time
from dataclasses import dataclass
from typing import Any

__all__ = ["Gpsd", "Orientation", "SiteConfig", "where"]

_LOGGER = logging.getLogger(__name__)

FRESH_S = 10.0
"""A fix older than this no longer says where the rig is (the scientist has walked)."""


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
