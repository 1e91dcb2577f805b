"""The msgpack envelope every bus message travels in; decoding is strict and bounded.

A map with short keys: ``v`` protocol major, ``mv`` minor, ``k`` kind, ``seq`` the
sender's counter, ``ts`` wall-clock nanoseconds, ``src`` the sender, ``corr`` (optional)
the id tying a command to its Ack, ``body`` the kind's fields. Unknown envelope keys are
ignored; anything malformed, oversized or of another major raises a
:class:`~protocol.errors.ProtocolError` whose text can go back to the sender.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import msgpack

from .errors import DecodeError, VersionError
from .version import PROTOCOL_MAJOR, PROTOCOL_MINOR, compatible

__all__ = ["MAX_MESSAGE", "Envelope", "decode", "encode"]

MAX_MESSAGE = 8 * 1024 * 1024
"""Largest accepted message (a full-resolution PNG chip fits; anything bigger is refused)."""
_MAX_ITEMS = 10_000
_MAX_TEXT = 64 * 1024


@dataclass(frozen=True)
class Envelope:
    kind: str
    body: dict[str, Any]
    seq: int = 0
    src: str = ""
    corr: str | None = None
    ts: int = field(default_factory=time.time_ns)
    minor: int = PROTOCOL_MINOR


def encode(
    kind: str,
    body: dict[str, Any],
    *,
    seq: int = 0,
    src: str = "",
    corr: str | None = None,
    ts: int | None = None,
) -> bytes:
    """Pack one message.

    >>> decode(encode("hello", {"build": "x"}, seq=3)).body
    {'build': 'x'}
    """
    env: dict[str, Any] = {
        "v": PROTOCOL_MAJOR,
        "mv": PROTOCOL_MINOR,
        "k": kind,
        "seq": seq,
        "ts": time.time_ns() if ts is None else ts,
        "src": src,
        "body": body,
    }
    if corr is not None:
        env["corr"] = corr
    return msgpack.packb(env, use_bin_type=True)


def _no_ext(code: int, data: bytes) -> Any:
    raise DecodeError(f"msgpack extension type {code} is not part of the protocol")


def decode(data: bytes | bytearray | memoryview, *, max_size: int = MAX_MESSAGE) -> Envelope:
    """Unpack and check one message; raise a ProtocolError on anything malformed.

    >>> decode(b"\\x92\\x01\\x02")
    Traceback (most recent call last):
    ...
    protocol.errors.DecodeError: not a msgpack map: list
    """
    if len(data) > max_size:
        raise DecodeError(f"message of {len(data)} bytes exceeds the {max_size}-byte limit")
    try:
        env = msgpack.unpackb(
            bytes(data),
            raw=False,
            strict_map_key=True,
            ext_hook=_no_ext,
            max_str_len=_MAX_TEXT,
            max_bin_len=max_size,
            max_array_len=_MAX_ITEMS,
            max_map_len=_MAX_ITEMS,
        )
    except DecodeError:
        raise
    except (ValueError, TypeError, msgpack.UnpackException, RecursionError) as exc:
        raise DecodeError(f"not valid msgpack: {exc or type(exc).__name__}") from None
    if not isinstance(env, dict):
        raise DecodeError(f"not a msgpack map: {type(env).__name__}")
    major = env.get("v")
    if not isinstance(major, int) or isinstance(major, bool):
        raise DecodeError("envelope has no protocol major 'v'")
    if not compatible(major):
        raise VersionError(
            f"protocol {PROTOCOL_MAJOR} required: this side speaks {PROTOCOL_MAJOR}."
            f"{PROTOCOL_MINOR}, the message is {major}.x; update the other side"
        )
    kind, body = env.get("k"), env.get("body", {})
    if not isinstance(kind, str) or not kind:
        raise DecodeError("envelope has no kind 'k'")
    if not isinstance(body, dict):
        raise DecodeError(f"body of {kind!r} is not a map")
    seq, ts, src, corr = env.get("seq", 0), env.get("ts", 0), env.get("src", ""), env.get("corr")
    minor = env.get("mv", 0)
    for name, value, kinds in (
        ("seq", seq, int),
        ("ts", ts, int),
        ("src", src, str),
        ("mv", minor, int),
    ):
        if not isinstance(value, kinds) or isinstance(value, bool):
            raise DecodeError(f"envelope field {name!r} has the wrong type")
    if corr is not None and not isinstance(corr, str):
        raise DecodeError("envelope field 'corr' has the wrong type")
    return Envelope(kind, body, seq, src, corr, ts, minor)
