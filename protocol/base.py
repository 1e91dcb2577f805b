"""The base of every message: typed fields, checked when a peer's message is decoded.

Tolerant: unknown fields are ignored and fields missing from an older peer take their
defaults. Strict: a present field of the wrong type, a non-finite number or an
out-of-range value raises :class:`~protocol.errors.InvalidFieldError`, so malformed
commands never reach the hardware.
"""

from __future__ import annotations

import math
import types
import typing
from dataclasses import MISSING, asdict, dataclass, fields
from typing import Any, ClassVar, Self

from .errors import DecodeError, InvalidFieldError

__all__ = ["MAX_TEXT", "RESULTS", "Message", "clip", "in_range"]

RESULTS = ("OK", "REJECTED", "LIMIT", "TIMEOUT", "BUSY", "ERROR")
MAX_TEXT = 4096
"""Longest text field either side accepts; what a rig sends is clipped to it (:func:`clip`)."""


def clip(text: str, limit: int = MAX_TEXT) -> str:
    """``text`` cut to ``limit`` characters (an ellipsis says so), so a peer can always
    decode what it is sent, however long the input it echoes.

    >>> clip("abcdef", 4), clip("abc", 4)
    ('abc…', 'abc')
    """
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _check(name: str, value: Any, tp: Any) -> Any:
    """``value`` converted to ``tp`` (int, float, str, bool, bytes, X | None, tuple[X, ...],
    or a Message), or InvalidFieldError."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = typing.get_args(tp)
        if value is None and type(None) in args:
            return None
        (inner,) = [a for a in args if a is not type(None)]
        return _check(name, value, inner)
    if origin is tuple:
        inner = typing.get_args(tp)[0]
        if not isinstance(value, list | tuple):
            raise InvalidFieldError(f"{name}: expected a list")
        return tuple(_check(f"{name}[{i}]", v, inner) for i, v in enumerate(value))
    if isinstance(tp, type) and issubclass(tp, Message):
        if not isinstance(value, dict):
            raise InvalidFieldError(f"{name}: expected a map")
        return tp.from_body(value)
    if tp is bool:
        if not isinstance(value, bool):
            raise InvalidFieldError(f"{name}: expected true/false")
        return value
    if tp is int:
        if not isinstance(value, int) or isinstance(value, bool):
            raise InvalidFieldError(f"{name}: expected an integer")
        return value
    if tp is float:
        if not isinstance(value, int | float) or isinstance(value, bool):
            raise InvalidFieldError(f"{name}: expected a number")
        if not math.isfinite(value):
            raise InvalidFieldError(f"{name}: must be finite")
        return float(value)
    if tp is str:
        if not isinstance(value, str) or len(value) > MAX_TEXT:
            raise InvalidFieldError(f"{name}: expected text of at most {MAX_TEXT} characters")
        return value
    if tp is bytes:
        if not isinstance(value, bytes):
            raise InvalidFieldError(f"{name}: expected binary data")
        return value
    raise TypeError(f"unsupported field type {tp!r}")


@dataclass(frozen=True)
class Message:
    """Base of every message; ``KIND`` names it in the envelope."""

    KIND: ClassVar[str] = ""

    @classmethod
    def from_body(cls, body: dict[str, Any]) -> Self:
        hints = typing.get_type_hints(cls)
        values = {}
        for f in fields(cls):
            if f.name in body:
                values[f.name] = _check(
                    f"{cls.KIND or cls.__name__}.{f.name}", body[f.name], hints[f.name]
                )
            elif f.default is MISSING and f.default_factory is MISSING:
                raise DecodeError(f"{cls.KIND}: missing field {f.name!r}")
        try:
            return cls(**values)
        except ValueError as exc:
            raise InvalidFieldError(f"{cls.KIND}: {exc}") from None

    def to_body(self) -> dict[str, Any]:
        return asdict(self)


def in_range(name: str, value: float, lo: float, hi: float) -> None:
    """ValueError unless ``lo <= value <= hi``: a field's range, checked in ``__post_init__``."""
    if not lo <= value <= hi:
        raise ValueError(f"{name} {value} outside {lo}..{hi}")
