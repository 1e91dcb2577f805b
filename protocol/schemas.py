"""JSON schemas of the protocol's messages, derived from their dataclasses.

The session log stores each message as JSON under a ``jsonschema`` schema, so Foxglove
and any MCAP reader can name, plot and filter its fields. The schema is derived here from
the message's own class (its type hints, defaults and field docstrings), the same
declaration :meth:`Message.from_body` checks against: one source, no hand-written copy.
Binary fields are left out, as :func:`protocol.recording.to_json` leaves them out, and so
are unknown (None) values: an optional field has its one type and is not required, since
Foxglove's JSON-schema reader takes a single ``type`` per field (no ``["number", "null"]``)
and a field left out decodes to its default, None.

Pure: reads the classes (and their source, for field docstrings), nothing else.
"""

from __future__ import annotations

import ast
import inspect
import itertools
import textwrap
import types
import typing
from dataclasses import MISSING, fields
from typing import Any

from .base import Message

__all__ = ["message_schema"]

_PRIMITIVES: dict[Any, str] = {bool: "boolean", int: "integer", float: "number", str: "string"}


def message_schema(cls: type[Message]) -> dict[str, Any]:
    """The JSON schema of ``cls``'s JSON form: its fields (binary ones left out), those
    without a default required.

    >>> from .replies import SurveyProgress
    >>> s = message_schema(SurveyProgress)
    >>> s["title"], s["required"], s["properties"]["eta_s"]["type"]
    ('cyborg.survey.progress', ['station', 'stage'], 'number')
    """
    hints = typing.get_type_hints(cls)
    docs = _field_docs(cls)
    properties: dict[str, Any] = {}
    required = []
    for f in fields(cls):
        if hints[f.name] is bytes:
            continue
        if _optional(hints[f.name]) and f.default is not None:
            raise TypeError(f"{cls.__name__}.{f.name}: an optional field must default to None")
        prop = _type_schema(hints[f.name])
        if f.name in docs:
            prop["description"] = docs[f.name]
        properties[f.name] = prop
        if f.default is MISSING and f.default_factory is MISSING:
            required.append(f.name)
    schema: dict[str, Any] = {"title": f"cyborg.{cls.KIND}", "type": "object"}
    doc = cls.__dict__.get("__doc__") or ""
    if doc and not doc.startswith(f"{cls.__name__}("):  # not the dataclass's signature
        schema["description"] = _one_line(doc)
    return schema | {"properties": properties, "required": required}


def _type_schema(tp: Any) -> dict[str, Any]:
    """The schema of one field type: the types :func:`protocol.base._check` accepts."""
    origin = typing.get_origin(tp)
    if _optional(tp):
        (inner,) = [a for a in typing.get_args(tp) if a is not type(None)]
        return _type_schema(inner)
    if origin is tuple:
        return {"type": "array", "items": _type_schema(typing.get_args(tp)[0])}
    if isinstance(tp, type) and issubclass(tp, Message):
        return message_schema(tp)
    if tp in _PRIMITIVES:
        return {"type": _PRIMITIVES[tp]}
    raise TypeError(f"no JSON schema for field type {tp!r}")


def _optional(tp: Any) -> bool:
    return typing.get_origin(tp) in (typing.Union, types.UnionType)


def _field_docs(cls: type) -> dict[str, str]:
    """The docstrings written under ``cls``'s own fields (none when its source is not
    at hand)."""
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    except (OSError, TypeError, SyntaxError):
        return {}
    body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
    docs = {}
    for node, after in itertools.pairwise(body):
        if (
            isinstance(node, ast.AnnAssign)
            and isinstance(node.target, ast.Name)
            and isinstance(after, ast.Expr)
            and isinstance(after.value, ast.Constant)
            and isinstance(after.value.value, str)
        ):
            docs[node.target.id] = _one_line(after.value.value)
    return docs


def _one_line(doc: str) -> str:
    return " ".join(doc.split())
