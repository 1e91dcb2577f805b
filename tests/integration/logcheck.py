"""A session log checked as a stranger would: opened with the official ``mcap`` reader
(its summary and chunk indexes, CRCs checked), every message validated against the schema
its channel names, and that schema the one the project ships (Foxglove's, vendored, for
``foxglove.*``; the one derived from the protocol's classes for ``cyborg.*``).

``jsonschema`` is not a dependency; :func:`validate` is a small validator of the keywords
these schemas use (type, required, properties, items, minItems, maxItems, minimum,
maximum, oneOf, const, contentEncoding base64), and fails on any other."""

from __future__ import annotations

import base64
import binascii
import json
from pathlib import Path
from typing import Any

from mcap.reader import make_reader

from cyborg.protocol import recording as rec

__all__ = ["Checked", "validate"]

_TYPES: dict[str, type | tuple[type, ...]] = {
    "object": dict,
    "array": list,
    "string": str,
    "integer": int,
    "number": (int, float),
    "boolean": bool,
    "null": type(None),
}
_ANNOTATIONS = {"$comment", "title", "description"}


def validate(doc: Any, schema: dict[str, Any], where: str = "$") -> None:
    """AssertionError naming the first place ``doc`` breaks ``schema``."""
    unknown = (
        set(schema)
        - _ANNOTATIONS
        - {
            *("type", "required", "properties", "items", "minItems", "maxItems"),
            *("minimum", "maximum", "oneOf", "const", "contentEncoding"),
        }
    )
    assert not unknown, f"{where}: the validator does not know {sorted(unknown)}"
    if "type" in schema:
        kinds = schema["type"] if isinstance(schema["type"], list) else [schema["type"]]
        numeric = ("integer", "number")
        assert any(
            isinstance(doc, _TYPES[k]) and not (isinstance(doc, bool) and k in numeric)
            for k in kinds
        ), f"{where}: {doc!r} is not {' or '.join(kinds)}"
    if "const" in schema:
        assert doc == schema["const"], f"{where}: {doc!r} is not {schema['const']!r}"
    if "oneOf" in schema:
        fits = sum(_fits(doc, s, where) for s in schema["oneOf"])
        assert fits == 1, f"{where}: {doc!r} fits {fits} of oneOf"
    if isinstance(doc, int | float) and not isinstance(doc, bool):
        assert doc >= schema.get("minimum", doc) and doc <= schema.get("maximum", doc), where
    if isinstance(doc, str) and schema.get("contentEncoding") == "base64":
        try:
            base64.b64decode(doc, validate=True)
        except binascii.Error:
            raise AssertionError(f"{where}: not base64") from None
    if isinstance(doc, dict):
        for name in schema.get("required", []):
            assert name in doc, f"{where}: missing {name}"
        for name, sub in schema.get("properties", {}).items():
            if name in doc:
                validate(doc[name], sub, f"{where}.{name}")
    if isinstance(doc, list):
        assert schema.get("minItems", 0) <= len(doc) <= schema.get("maxItems", len(doc)), where
        for i, item in enumerate(doc):
            validate(item, schema.get("items", {}), f"{where}[{i}]")


def _fits(doc: Any, schema: dict[str, Any], where: str) -> bool:
    try:
        validate(doc, schema, where)
    except AssertionError:
        return False
    return True


class Checked:
    """A session log read back: its metadata by name and its messages, decoded, in log
    time order as (topic, schema name, log time, JSON document)."""

    def __init__(self, path: Path) -> None:
        self.metadata: dict[str, dict[str, str]] = {}
        self.messages: list[tuple[str, str, int, Any]] = []
        with path.open("rb") as f:
            reader = make_reader(f, validate_crcs=True)
            for schema, channel, message in reader.iter_messages(log_time_order=True):
                assert schema is not None and schema.encoding == "jsonschema", channel.topic
                assert schema.data == rec.schema_data(schema.name), schema.name
                doc = json.loads(message.data)
                validate(doc, json.loads(schema.data), f"{channel.topic}@{message.log_time}")
                self.messages.append((channel.topic, schema.name, message.log_time, doc))
            for record in reader.iter_metadata():
                self.metadata[record.name] = dict(record.metadata)
            summary = reader.get_summary()
            assert summary is not None
            self.schemas = sorted(s.name for s in summary.schemas.values())

    def on(self, topic: str) -> list[Any]:
        """The documents logged on ``topic``."""
        return [doc for t, _, _, doc in self.messages if t == topic]
