"""The one door to zenoh: a session opened from a :class:`~.transport.Transport`, and
zenoh's callbacks handed to asyncio. Every side (the daemon, the router, each client,
replay, the benchmarks and the tests) opens its sessions here.

The one module of ``protocol`` that imports zenoh and asyncio; the rest of the package is
the pure wire contract.

zenoh-python 1.x is synchronous and calls back on its own threads. The callbacks built here
run on zenoh's network thread (``indirect=False``), so no Python thread outlives the
session, which would otherwise hang interpreter exit (zenoh-python#434). They never block
and never call zenoh: they copy what they keep out of the sample and hand it to the event
loop with ``call_soon_threadsafe``.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import os
import re
from collections.abc import Callable, Mapping
from typing import Any, TypeVar

import zenoh

from .transport import Transport

__all__ = [
    "ADMIN_SPACE",
    "SOCKET_MODE",
    "locators",
    "on_thread",
    "open_session",
    "plain",
    "send_reply",
    "to_loop",
]

T = TypeVar("T")

_LOGGER = logging.getLogger(__name__)

SOCKET_MODE = 0o660
"""The rig's unix sockets: its own user and group (the scientist's account joins group
``cyborg``). zenoh creates them by the umask, and connecting needs write permission."""
ADMIN_SPACE = {"adminspace/enabled": "true"}
"""The ``extra`` settings of a router whose :func:`locators` are read back."""


def open_session(transport: Transport, extra: Mapping[str, str] | None = None) -> zenoh.Session:
    """A zenoh session with ``transport``'s settings (scouting off, explicit endpoints);
    ``extra`` sets more keys by path, as JSON5 values (:data:`ADMIN_SPACE`, a test's link
    timeout). The unix sockets it listens on get :data:`SOCKET_MODE`."""
    cfg = zenoh.Config.from_json5(transport.json5())
    for key, value in (extra or {}).items():
        cfg.insert_json5(key, value)
    try:
        session = zenoh.open(cfg)
    except zenoh.ZError as exc:  # a port in use, nobody at the endpoint: said plainly
        raise zenoh.ZError(plain(exc)) from None
    for path in transport.unix_sockets():
        os.chmod(path, SOCKET_MODE)
    return session


_RUST_SOURCE = re.compile(r"\s+at \S+\.rs:\d+\.?")


def plain(exc: BaseException) -> str:
    """A zenoh error without the Rust source locations it carries (they mean nothing to the
    person whose port is taken).

    >>> plain(ValueError("bind: [127.0.0.1:7447: Address in use at /x/tcp.rs:61.] at /y.rs:3."))
    'bind: [127.0.0.1:7447: Address in use]'
    """
    return _RUST_SOURCE.sub("", str(exc)).strip()


def locators(session: zenoh.Session, timeout: float = 5.0) -> list[str]:
    """The endpoints a router session (opened with :data:`ADMIN_SPACE`) listens on, read
    back from its admin space: a port 0 becomes the port the kernel picked."""
    info = next(iter(session.get(f"@/{session.zid()}/router", timeout=timeout)))
    return json.loads(info.ok.payload.to_string())["locators"]


def on_thread(fn: Callable[[Any], object]) -> zenoh.handlers.Callback:
    """A zenoh callback calling ``fn`` with each sample or query on zenoh's network thread
    (a benchmark's clock reads the arrival there); ``fn`` must neither block nor call zenoh."""
    return zenoh.handlers.Callback(fn, indirect=False)


def to_loop(
    fn: Callable[[T], object], pick: Callable[[Any], T | None] | None = None
) -> zenoh.handlers.Callback:
    """A zenoh callback calling ``fn`` on the running event loop (call this on it) with each
    sample or query, or with what ``pick`` makes of it on zenoh's thread: the bytes copied
    out of a sample, or None to drop it. Nothing is handed over once the loop has closed."""
    loop = asyncio.get_running_loop()

    def hand_off(item: Any) -> None:
        value = item if pick is None else pick(item)
        if value is None:
            return
        with contextlib.suppress(RuntimeError):  # the loop closed: shutting down
            loop.call_soon_threadsafe(fn, value)

    return on_thread(hand_off)


def send_reply(query: zenoh.Query, reply: bytes | None, error: bytes) -> None:
    """Answer ``query`` with ``reply``, or with ``error`` when it is None, and finish it. It
    blocks while the querier's link is congested: call it on a reply thread, never the loop.
    A querier gone meanwhile is no error of the answering side."""
    with query:
        try:
            if reply is None:
                query.reply_err(error)
            else:
                query.reply(query.key_expr, reply)
        except zenoh.ZError as exc:
            _LOGGER.debug("reply not sent: %s", exc)
