"""The session log's schemas and Foxglove messages on their own: the protocol's schemas,
derived from its classes, accept what the protocol accepts and refuse what it refuses;
a station's position becomes a LocationFix that fits Foxglove's schema, or nothing."""

from __future__ import annotations

import json
from typing import Any

import pytest

from cyborg.protocol import recording as rec
from cyborg.protocol.errors import ProtocolError
from cyborg.protocol.messages import (
    MESSAGES,
    Chip,
    FrameHeader,
    InterestPoint,
    InterestResult,
    Message,
    PtuState,
    SurveyProgress,
)
from tests.integration.logcheck import validate

POINT = InterestPoint(1, 10.0, 20.0, 4.3, 12.5, -3.0, "green patch on orange rock", 2.5, 8.0, 0.7)
RECORDED: list[Message] = [
    PtuState(1.5, -2.0, True, "ready", "alice"),
    SurveyProgress("s/st01-300m", "tiles", 2, 6, None),
    InterestResult(
        "s/st01-300m", (POINT, InterestPoint(2, 1.0, 2.0, 0.01, 0.0, 0.0, target=False))
    ),
    Chip("s/st01-300m", 1, 12.5, -3.0, "chips/chip_1.jpg", b"\xff\xd8"),
    FrameHeader(7, 640, 480, None, 3.0),
]


def _schema(kind: str) -> dict[str, Any]:
    return json.loads(rec.schema_data(rec.schema_name(kind)))


def _accepted(kind: str, body: dict[str, Any]) -> tuple[bool, bool]:
    """(the protocol decodes ``body``, the schema validates it)."""
    try:
        MESSAGES[kind].from_body(body)
        decoded = True
    except ProtocolError:
        decoded = False
    try:
        validate(body, _schema(kind))
        valid = True
    except AssertionError:
        valid = False
    return decoded, valid


@pytest.mark.parametrize("msg", RECORDED, ids=lambda m: m.KIND)
def test_a_recorded_message_fits_its_schema_and_round_trips(msg: Message) -> None:
    data = rec.to_json(msg)
    validate(json.loads(data), _schema(msg.KIND))
    back = rec.from_json(msg.KIND, data)
    assert back is not None and rec.to_json(back) == data  # all but the bytes, which are images
    _foxglove_reads(_schema(msg.KIND))


@pytest.mark.parametrize("msg", RECORDED, ids=lambda m: m.KIND)
def test_the_schema_refuses_what_the_protocol_refuses(msg: Message) -> None:
    doc = json.loads(rec.to_json(msg))
    schema = _schema(msg.KIND)
    for name in schema["required"]:
        assert _accepted(msg.KIND, {k: v for k, v in doc.items() if k != name}) == (False, False)
    for name, value in doc.items():
        wrong = "text" if not isinstance(value, str) else 1.5
        assert _accepted(msg.KIND, doc | {name: wrong}) == (False, False), name
        if name not in schema["required"]:  # left out, it takes its default
            assert _accepted(msg.KIND, {k: v for k, v in doc.items() if k != name}) == (True, True)


def _foxglove_reads(schema: dict[str, Any]) -> None:
    """What Foxglove's JSON-schema reader takes (foxglove/studio, mcap-support,
    parseJsonSchema.ts): objects with properties, each field of one type, arrays of one."""
    assert schema["type"] == "object" and "properties" in schema
    for name, field in schema["properties"].items():
        kind = field["type"]
        assert kind in ("boolean", "string", "number", "integer", "object", "array"), name
        if kind == "object":
            _foxglove_reads(field)
        if kind == "array":
            item = field["items"]
            assert item["type"] in ("boolean", "string", "number", "integer", "object"), name
            if item["type"] == "object":
                _foxglove_reads(item)


def test_every_message_has_a_named_schema_foxglove_reads_with_its_field_docs() -> None:
    for kind in MESSAGES:
        assert _schema(kind)["title"] == f"cyborg.{kind}"
        _foxglove_reads(_schema(kind))
    point = _schema("survey.result")["properties"]["points"]["items"]
    assert point["title"] == "cyborg.interest.point"
    assert point["properties"]["azimuth"]["description"].startswith("True azimuth")


def test_a_station_position_is_a_location_fix_or_nothing() -> None:
    schema = json.loads(rec.foxglove_schema("LocationFix"))
    leg = {"from": "st01-300m", "bearing_deg": 42.0, "distance_m": 240.0}
    site = {"name": "cliff", "latitude": 40.3, "longitude": -3.5, "altitude": None}
    fix = json.loads(
        rec.location_fix(5, "s/st02-60m", site | {"source": "dead-reckoned", "leg": leg})
    )
    validate(fix, schema)
    assert (fix["latitude"], fix["longitude"], fix["altitude"]) == (40.3, -3.5, 0.0)
    assert fix["position_covariance_type"] == rec.COVARIANCE_UNKNOWN
    meta = {p["key"]: p["value"] for p in fix["metadata"]}
    assert meta["altitude"] == "unknown" and meta["source"] == "dead-reckoned"
    assert meta["leg.distance_m"] == "240.0" and meta["station"] == "s/st02-60m"
    unknown = {"latitude": None, "longitude": None, "source": "unknown"}
    assert rec.location_fix(5, "s/st01-300m", unknown) is None


def test_annotations_ring_targets_with_short_labels_and_keep_the_reason() -> None:
    why = "dark orange patch, darker than 82 % of the image; 0.37 % of the area; new"
    point = InterestPoint(1, 10.0, 20.0, 4.3, 12.5, -3.0, why)
    noise = InterestPoint(2, 1, 2, 0.01, 0, 0, "orange spot", target=False)
    doc = json.loads(rec.annotations(9, InterestResult("s/st01", (point, noise)), {1: 6.0}))
    validate(doc, json.loads(rec.foxglove_schema("ImageAnnotations")))
    (ring,), (text,) = doc["circles"], doc["texts"]  # no ring for what is no target
    assert text["text"] == "#1 dark orange patch"
    assert {"key": "why", "value": why} in text["metadata"]
    assert ring["metadata"] == text["metadata"]
