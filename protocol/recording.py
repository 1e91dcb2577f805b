"""The session log's layout: which MCAP topic carries what, and how messages become JSON.

One file per session, ``<archive>/<session>/session.mcap``, every message JSON-encoded
(``jsonschema`` schemas) so Foxglove and any MCAP reader open it with no plugin:

* the rig's own telemetry, as the protocol's messages (schema ``cyborg.<kind>``): the PTU
  state, survey progress, results, chip and live-frame headers. Replay publishes these
  back on the bus. Binary fields (a chip's JPEG) are left out of the JSON: the image
  follows as the next message, at the same log time, on the paired image topic;
* Foxglove's types for viewing: live frames, chips and mosaics as
  ``foxglove.CompressedImage``, the interest points as ``foxglove.ImageAnnotations`` on
  their mosaic, events as ``foxglove.Log``, and the camera's pose on the rig as
  ``foxglove.FrameTransform`` (parent ``rig``: x ahead at pan 0, y left, z up; child
  ``camera``: yaw = -pan, pitch = -tilt, since pan turns right and tilt up).

Pure: no files, no MCAP library; the daemon writes, the clients replay.
"""

from __future__ import annotations

import base64
import json
import math
from dataclasses import fields
from importlib import resources
from typing import Any

from .messages import MESSAGES, Event, InterestResult, Message
from .palette import POINT_RGB, unit_rgb

__all__ = [
    "ANNOTATIONS",
    "IMAGE_TOPICS",
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
    "log_entry",
    "schema_name",
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

LOG_LEVELS = {"debug": 1, "info": 2, "warning": 3, "error": 4}
"""Event levels as foxglove.Log levels (and back)."""

_COLOURS = [unit_rgb(rgb) for rgb in POINT_RGB]
"""Ranks 1..3, as the overlay draws them."""


def schema_name(kind: str) -> str:
    return f"cyborg.{kind}"


def to_json(msg: Message) -> bytes:
    """A protocol message as JSON, binary fields left out (they travel as images)."""
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
        return {k: _plain(v) for k, v in value.items() if not isinstance(v, bytes)}
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
    """foxglove.ImageAnnotations: a ring and a label per point, on the mosaic logged at
    ``ns`` (``radii``: rank -> the target's radius in mosaic pixels)."""
    circles, texts = [], []
    for p in result.points:
        r, g, b = _COLOURS[(p.rank - 1) % len(_COLOURS)]
        colour = {"r": r, "g": g, "b": b, "a": 1.0}
        radius = max(radii.get(p.rank, 0.0), 4.0) + 3.0
        circles.append(
            {
                "timestamp": stamp(ns),
                "position": {"x": p.x + 0.5, "y": p.y + 0.5},
                "diameter": 2 * radius,
                "thickness": 2.0,
                "fill_color": {"r": 0.0, "g": 0.0, "b": 0.0, "a": 0.0},
                "outline_color": colour,
            }
        )
        texts.append(
            {
                "timestamp": stamp(ns),
                "position": {"x": p.x + 0.5 + radius + 2, "y": p.y + 0.5},
                "text": f"{p.rank}: {p.why}" if p.why else str(p.rank),
                "font_size": 12.0,
                "text_color": colour,
                "background_color": {"r": 0.0, "g": 0.0, "b": 0.0, "a": 0.6},
            }
        )
    return json.dumps({"circles": circles, "points": [], "texts": texts}).encode()


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
