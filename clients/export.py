"""A session's interest points as a table (CSV) or a map layer (GeoJSON), from the station
manifests: for a spreadsheet, a GIS, or finding the spots again next season.

Each station stands where its manifest's ``site`` says (a GPS fix, the configured site, or
dead-reckoned along the walk); each point has the azimuth and elevation from its station
and, where a range was known, its target's estimated position. The GeoJSON (RFC 7946:
longitude, latitude[, altitude]; no position, ``null`` geometry) has a feature per station,
one per point (at its target's estimated position, else at its station, ``located`` says
which) and the session's walk as a line; ``feature`` tells them apart.
"""

from __future__ import annotations

import csv
import io
from typing import Any

__all__ = ["COLUMNS", "point_rows", "to_csv", "to_geojson"]

COLUMNS = (
    "session",
    "station",
    "distance_m",
    "started",
    "rank",
    "score",
    "reason",
    "pan",
    "tilt",
    "azimuth",
    "elevation",
    "latitude",
    "longitude",
    "altitude",
    "site",
    "chosen",
    "station_source",
    "leg_from",
    "leg_bearing_deg",
    "leg_distance_m",
    "target_latitude",
    "target_longitude",
    "target_altitude",
    "range_m",
    "aim",
)
"""The CSV's columns: a contract (new ones are only ever added at the end). ``latitude``,
``longitude``, ``altitude`` and ``site`` are the station's; ``target_*`` the point's
estimated position, ``range_m`` the range it was estimated at; ``aim`` the station's aim of
study (``protocol.aims``; empty for a station recorded before aims)."""


def point_rows(manifests: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per interest point of every station, in station order.

    >>> m = {"session": "s", "station": "st01-300m", "distance_m": 300, "started": "t",
    ...      "points": [{"rank": 1, "score": 2.0, "pan": 3.0, "tilt": -1.0, "why": "x",
    ...                  "azimuth": 93.0, "elevation": -1.0}],
    ...      "site": {"latitude": 40.3, "longitude": -3.5, "name": "Rivas"},
    ...      "choice": {"rank": 1}}
    >>> row = point_rows([m])[0]
    >>> row["azimuth"], row["latitude"], row["site"], row["chosen"]
    (93.0, 40.3, 'Rivas', True)
    >>> ",Rivas,true,unknown,,,,,,," in to_csv([row]).splitlines()[1]
    True
    """
    rows = []
    for m in _in_order(manifests):
        aim = _aim(m)
        site = m.get("site") or {}
        leg = site.get("leg") or {}
        chosen = (m.get("choice") or {}).get("rank")
        for p in m.get("points", []):
            target = p.get("position") or {}
            rows.append(
                {
                    "session": m.get("session", ""),
                    "station": m.get("station", ""),
                    "distance_m": m.get("distance_m"),
                    "started": m.get("started", ""),
                    "rank": p["rank"],
                    "score": p.get("score"),
                    "reason": p.get("why", ""),
                    "pan": p.get("pan"),
                    "tilt": p.get("tilt"),
                    "azimuth": p.get("azimuth"),
                    "elevation": p.get("elevation"),
                    "latitude": site.get("latitude"),
                    "longitude": site.get("longitude"),
                    "altitude": site.get("altitude"),
                    "site": site.get("name", ""),
                    "chosen": chosen == p["rank"],
                    "station_source": site.get("source", "unknown"),
                    "leg_from": leg.get("from", ""),
                    "leg_bearing_deg": leg.get("bearing_deg"),
                    "leg_distance_m": leg.get("distance_m"),
                    "target_latitude": target.get("latitude"),
                    "target_longitude": target.get("longitude"),
                    "target_altitude": target.get("altitude"),
                    "range_m": target.get("range_m"),
                    "aim": aim,
                }
            )
    return rows


def to_csv(rows: list[dict[str, Any]]) -> str:
    out = io.StringIO()
    writer = csv.DictWriter(out, COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: _cell(row[k]) for k in COLUMNS})
    return out.getvalue()


def _cell(value: Any) -> Any:
    """A CSV cell: empty for unknown, ``true``/``false`` as JSON and GIS tools write them."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    return value


def _aim(manifest: dict[str, Any]) -> str:
    """The aim of study the station's plan records."""
    return str((manifest.get("plan") or {}).get("aim") or "")


def _in_order(manifests: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return sorted(manifests, key=lambda m: (m.get("session", ""), m.get("index", 0)))


def _point(lon: float | None, lat: float | None, alt: float | None) -> dict[str, Any] | None:
    """A GeoJSON Point, or None (a ``null`` geometry) where the place is unknown."""
    if lon is None or lat is None:
        return None
    return {"type": "Point", "coordinates": [lon, lat] if alt is None else [lon, lat, alt]}


def to_geojson(manifests: list[dict[str, Any]]) -> dict[str, Any]:
    """Stations, points and walks (module doc) as one FeatureCollection.

    >>> m = {"session": "s", "station": "st02-60m", "distance_m": 60, "index": 2,
    ...      "site": {"latitude": 40.3, "longitude": -3.5, "source": "dead-reckoned",
    ...               "leg": {"from": "st01-300m", "bearing_deg": 90.0, "distance_m": 240.0}},
    ...      "points": [{"rank": 1, "azimuth": 90.0,
    ...                  "position": {"latitude": 40.3, "longitude": -3.49, "range_m": 60}}]}
    >>> station, point = to_geojson([m])["features"]
    >>> station["properties"]["source"], station["geometry"]["coordinates"]
    ('dead-reckoned', [-3.5, 40.3])
    >>> point["properties"]["located"], point["geometry"]["coordinates"]
    ('target', [-3.49, 40.3])
    """
    features = []
    walks: dict[str, list[list[float]]] = {}
    for m in _in_order(manifests):
        site = m.get("site") or {}
        where = _point(site.get("longitude"), site.get("latitude"), site.get("altitude"))
        props = {
            "feature": "station",
            "session": m.get("session", ""),
            "station": m.get("station", ""),
            "distance_m": m.get("distance_m"),
            "started": m.get("started", ""),
            "site": site.get("name", ""),
            "source": site.get("source", "unknown"),
            "leg": site.get("leg"),
            "chosen": (m.get("choice") or {}).get("rank"),
            "aim": _aim(m),
        }
        features.append({"type": "Feature", "geometry": where, "properties": props})
        if where is not None:
            walk = walks.setdefault(props["session"], [])
            if walk[-1:] != [where["coordinates"][:2]]:
                walk.append(where["coordinates"][:2])
    for row in point_rows(manifests):
        target = _point(row["target_longitude"], row["target_latitude"], row["target_altitude"])
        at = target or _point(row["longitude"], row["latitude"], row["altitude"])
        props = {"feature": "point", "located": "target" if target else "station", **row}
        features.append({"type": "Feature", "geometry": at, "properties": props})
    for session, line in walks.items():
        if len(line) > 1:
            geometry = {"type": "LineString", "coordinates": line}
            props = {"feature": "walk", "session": session}
            features.append({"type": "Feature", "geometry": geometry, "properties": props})
    return {"type": "FeatureCollection", "features": features}
