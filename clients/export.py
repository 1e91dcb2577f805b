"""A session's interest points as a table (CSV) or a map layer (GeoJSON), from the station
manifests: for a spreadsheet, a GIS, or finding the spots again next season.

A point's own position is unknown (the camera gives a direction, not a range), so each
GeoJSON feature sits at its station, with the azimuth and elevation to the target among
its properties (RFC 7946: longitude, latitude[, altitude]; no position, ``null`` geometry).
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
)


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
    >>> to_csv([row]).splitlines()[1].endswith(",Rivas,true")
    True
    """
    rows = []
    for m in sorted(manifests, key=lambda m: m.get("index", 0)):
        site = m.get("site") or {}
        chosen = (m.get("choice") or {}).get("rank")
        for p in m.get("points", []):
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


def to_geojson(rows: list[dict[str, Any]]) -> dict[str, Any]:
    features = []
    for row in rows:
        lon, lat, alt = row["longitude"], row["latitude"], row["altitude"]
        geometry = None
        if lon is not None and lat is not None:
            coords = [lon, lat] if alt is None else [lon, lat, alt]
            geometry = {"type": "Point", "coordinates": coords}
        props = {k: row[k] for k in COLUMNS if k not in ("latitude", "longitude", "altitude")}
        features.append({"type": "Feature", "geometry": geometry, "properties": props})
    return {"type": "FeatureCollection", "features": features}
