"""The session log's layout: which MCAP topic carries what, and how messages become JSON.

One file per session, ``<archive>/<session>/session.mcap``, every message JSON-encoded
under a ``jsonschema`` schema (:func:`schema_data`, each registered once) so Foxglove and
any MCAP reader open it with no plugin and name every field:

* the rig's own telemetry, as the protocol's messages (schema ``cyborg.<kind>``, derived
  from the message's class by :mod:`protocol.schemas`): the PTU state, survey progress,
  results, chip and live-frame headers. Replay publishes these back on the bus. Unknown
  (None) values are left out, and so are binary fields (a chip's JPEG): the image follows
  as the next message, at the same log time, on the paired image topic, and is stored
  nowhere else;
* Foxglove's types for viewing (schemas vendored in ``protocol/foxglove``): live frames,
  chips and mosaics as ``foxglove.CompressedImage``; the interest points as
  ``foxglove.ImageAnnotations`` on their mosaic (same timestamp, no copy of the image): a
  ring and a short label each, the whole reason and the point's fields in the
  annotation's ``metadata``; each station's own position as ``foxglove.LocationFix``;
  events and every decision (a choice, a cancel, a HALT, a station left incomplete or
  failed) as ``foxglove.Log``; and the camera's pose on the rig as
  ``foxglove.FrameTransform`` (parent ``rig``: x ahead at pan 0, y left, z up; child
  ``camera``: yaw = -pan, pitch = -tilt, since pan turns right and tilt up).

The file's metadata holds ``session`` (the rig, its build and devices) and ``site``
(where the session's first station stood, :func:`site_metadata`).

Pure: no files, no MCAP library; the daemon writes, the clients replay.
"""

from __future__ import annotations

import base64
import json
import math
from dataclasses import fields
from importlib import resources
from typing import Any

from .messages import MESSAGES, Event, InterestPoint, InterestResult, Message
from .palette import POINT_RGB, unit_rgb
from .schemas import message_schema

__all__ = [
    "ANNOTATIONS",
    "IMAGE_TOPICS",
    "LOCATION",
    "LOG",
    "LOG_LEVELS",
    "MOSAIC",
    "TF",
    "TOPICS",
    "annotations",
    "compressed_image",
    "foxglove_schema",
    "frame_transform",
    "from_json",
    "label",
    "location_fix",
    "log_entry",
    "schema_data",
    "schema_name",
    "site_metadata",
    "stamp",
    "to_json",
]

TOPICS: dict[str, str] = {
    "ptu.state": "/ptu/state",
    "survey.progress": "/survey/progress",
    "survey.result": "/survey/result",
    "survey.chip": "/survey/chip",
    "cam.frame": "/cam/frame",
}
"""The protocol's telemetry kinds and their topics."""

IMAGE_TOPICS: dict[str, str] = {"survey.chip": "/survey/chip/image", "cam.frame": "/camera/live"}
"""Where the image of a message with one follows it."""

MOSAIC, ANNOTATIONS, LOG, TF = "/survey/mosaic", "/survey/annotations", "/log", "/tf"
LOCATION = "/location"
"""Each station's own position (foxglove.LocationFix), for Foxglove's map."""

LOG_LEVELS = {"debug": 1, "info": 2, "warning": 3, "error": 4}
"""Event levels as foxglove.Log levels (and back)."""

_COLOURS = [unit_rgb(rgb) for rgb in POINT_RGB]
"""Ranks 1..3, as the overlay draws them."""
LABEL_CHARS = 36
"""Longest label beside a ring: legible at 12 px on a mosaic a few hundred pixels wide."""
COVARIANCE_UNKNOWN = 0
"""foxglove.PositionCovarianceType UNKNOWN: what every station's fix says (location_fix)."""


def schema_name(kind: str) -> str:
    return f"cyborg.{kind}"


def schema_data(name: str) -> bytes:
    """The JSON schema registered for ``name``: Foxglove's own (vendored) for
    ``foxglove.*``, else the protocol message's, derived from its class."""
    if name.startswith("foxglove."):
        return foxglove_schema(name.removeprefix("foxglove."))
    return json.dumps(message_schema(MESSAGES[name.removeprefix("cyborg.")])).encode()


def to_json(msg: Message) -> bytes:
    """A protocol message as JSON, binary fields (they travel as images) and None values
    (decoded back as their default, None) left out."""
    body = {f.name: getattr(msg, f.name) for f in fields(msg)}
    return json.dumps(_plain(body), separators=(",", ":")).encode()


def from_json(kind: str, data: bytes) -> Message | None:
    """The message of a recorded kind (None for kinds this side does not know)."""
    cls = MESSAGES.get(kind)
    return None if cls is None else cls.from_body(json.loads(data))


def _plain(value: Any) -> Any:
    if isinstance(value, Message):
        return _plain({f.name: getattr(value, f.name) for f in fields(value)})
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items() if not isinstance(v, bytes | None)}
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    return value


def stamp(ns: int) -> dict[str, int]:
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


def compressed_image(ns: int, frame_id: str, fmt: str, data: bytes) -> bytes:
    """foxglove.CompressedImage (``fmt``: jpeg or png)."""
    doc = {
        "timestamp": stamp(ns),
        "frame_id": frame_id,
        "data": base64.b64encode(data).decode(),
        "format": fmt,
    }
    return json.dumps(doc).encode()


def log_entry(ns: int, event: Event, name: str) -> bytes:
    """foxglove.Log of an event."""
    doc = {
        "timestamp": stamp(ns),
        "level": LOG_LEVELS.get(event.level, 0),
        "message": event.text,
        "name": name,
        "file": "",
        "line": 0,
    }
    return json.dumps(doc).encode()


def annotations(ns: int, result: InterestResult, radii: dict[int, float]) -> bytes:
    """foxglove.ImageAnnotations: a ring and a short label (:func:`label`) per target, on
    the mosaic logged at ``ns`` (``radii``: rank -> the target's radius in mosaic pixels);
    each ring and label carries the point's fields, its whole reason among them, as
    metadata. A point that is no further target gets neither (it stays in the result)."""
    circles, texts = [], []
    for p in result.points:
        if not p.target:
            continue
        r, g, b = _COLOURS[(p.rank - 1) % len(_COLOURS)]
        colour = {"r": r, "g": g, "b": b, "a": 1.0}
        radius = max(radii.get(p.rank, 0.0), 4.0) + 3.0
        meta = _pairs({k: v for k, v in p.to_body().items() if k not in ("x", "y")})
        circles.append(
            {
                "timestamp": stamp(ns),
                "position": {"x": p.x + 0.5, "y": p.y + 0.5},
                "diameter": 2 * radius,
                "thickness": 2.0,
                "fill_color": {"r": 0.0, "g": 0.0, "b": 0.0, "a": 0.0},
                "outline_color": colour,
                "metadata": meta,
            }
        )
        texts.append(
            {
                "timestamp": stamp(ns),
                "position": {"x": p.x + 0.5 + radius + 2, "y": p.y + 0.5},
                "text": label(p),
                "font_size": 12.0,
                "text_color": colour,
                "background_color": {"r": 0.0, "g": 0.0, "b": 0.0, "a": 0.6},
                "metadata": meta,
            }
        )
    doc = {
        "circles": circles,
        "points": [],
        "texts": texts,
        "metadata": _pairs({"station": result.station}),
    }
    return json.dumps(doc).encode()


def label(point: InterestPoint) -> str:
    """A ring's label: the rank and the reason's first words, whole words only.

    >>> label(InterestPoint(2, 0, 0, 1.0, 0, 0, "dark orange patch, darker than 82 %; 0.4 %"))
    '#2 dark orange patch'
    >>> label(InterestPoint(1, 0, 0, 1.0, 0, 0, "green patch of an unusual tone or texture"))
    '#1 green patch of an unusual tone or…'
    """
    head = point.why.split(";")[0].split(",")[0].split()
    words: list[str] = []
    for word in head:
        if len(" ".join([*words, word])) > LABEL_CHARS:
            return " ".join([f"#{point.rank}", *words]) + "…"
        words.append(word)
    return " ".join([f"#{point.rank}", *words])


def location_fix(ns: int, station: str, site: dict[str, Any]) -> bytes | None:
    """foxglove.LocationFix of where a station stood (its manifest's ``site``), or None
    when the rig did not know.

    The covariance type is UNKNOWN, with zeros, whatever the ``source``: a configured
    site, a gpsd fix as the manifest keeps it and a dead-reckoned leg all lack a measured
    uncertainty, and an approximated one would be invented. ``source`` (with a
    dead-reckoned ``leg``) is in the fix's metadata, with the rest of the site; an unknown
    altitude is 0 there, and says so."""
    lat, lon, alt = site.get("latitude"), site.get("longitude"), site.get("altitude")
    if lat is None or lon is None:
        return None
    doc: dict[str, Any] = {
        "timestamp": stamp(ns),
        "frame_id": "rig",
        "latitude": float(lat),
        "longitude": float(lon),
        "altitude": 0.0 if alt is None else float(alt),
        "position_covariance": [0.0] * 9,
        "position_covariance_type": COVARIANCE_UNKNOWN,
    }
    if site.get("heading") is not None:
        doc["heading"] = math.radians(float(site["heading"]))  # clockwise from north
    unknown = {"altitude": "unknown"} if alt is None else {}
    doc["metadata"] = _pairs({"station": station} | site_metadata(site) | unknown)
    return json.dumps(doc).encode()


def site_metadata(site: dict[str, Any]) -> dict[str, str]:
    """A site record as MCAP metadata (text values; a leg's keys as ``leg.<key>``; unknown
    and empty values left out).

    >>> site_metadata({"name": "cliff", "latitude": 40.5, "altitude": None,
    ...                "leg": {"from": "st01-300m", "distance_m": 240.0}})
    {'name': 'cliff', 'latitude': '40.5', 'leg.from': 'st01-300m', 'leg.distance_m': '240.0'}
    """
    flat: dict[str, str] = {}
    for key, value in site.items():
        if isinstance(value, dict):
            flat |= {f"{key}.{k}": str(v) for k, v in value.items() if v not in (None, "")}
        elif value not in (None, ""):
            flat[key] = str(value)
    return flat


def _pairs(values: dict[str, Any]) -> list[dict[str, str]]:
    """foxglove.KeyValuePair items (text values; None left out)."""
    return [{"key": k, "value": str(v)} for k, v in values.items() if v is not None]


def frame_transform(ns: int, pan_deg: float, tilt_deg: float) -> bytes:
    """foxglove.FrameTransform rig -> camera for the head at (pan, tilt) degrees."""
    yaw, pitch = math.radians(-pan_deg), math.radians(-tilt_deg)
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
    doc = {
        "timestamp": stamp(ns),
        "parent_frame_id": "rig",
        "child_frame_id": "camera",
        "translation": {"x": 0.0, "y": 0.0, "z": 0.0},
        # yaw about z, then pitch about the turned y: q = q_yaw * q_pitch
        "rotation": {"x": -sy * sp, "y": cy * sp, "z": sy * cp, "w": cy * cp},
    }
    return json.dumps(doc).encode()


def foxglove_schema(name: str) -> bytes:
    """The vendored JSON schema of ``foxglove.<name>`` (protocol/foxglove, MIT)."""
    return resources.files(__package__).joinpath("foxglove", f"{name}.json").read_bytes()
