"""The daemon's side of the zenoh bus, bridged into asyncio.

zenoh-python 1.x is synchronous and calls back on its own threads. Callbacks here do one
thing: hand the data to the event loop with ``call_soon_threadsafe``. They run on the
network thread (``indirect=False``) so no Python thread outlives the session, which
would otherwise hang interpreter exit (zenoh-python#434). Replies and publications happen
on the loop thread; each is a short non-blocking call into the zenoh runtime.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import os
from collections.abc import Awaitable, Callable, Iterator

import zenoh

from protocol.envelope import encode
from protocol.errors import VersionError
from protocol.keys import Keys
from protocol.messages import Message, clip
from protocol.transport import Transport

__all__ = ["Bus", "CommandHandler", "open_session"]

_LOGGER = logging.getLogger(__name__)

CommandHandler = Callable[[str, str, bytes], Awaitable[bytes]]
"""(caller, verb, request payload) -> reply payload (an encoded envelope). The caller is the
``<client>`` segment of the key. A VersionError raised is sent as a plain-text error
reply, which a peer of any protocol version can read."""


SOCKET_MODE = 0o660
"""The rig's unix sockets: its own user and group (the scientist's account joins group
``cyborg``). zenoh creates them by the umask, and connecting needs write permission."""


def open_session(transport: Transport) -> zenoh.Session:
    session = zenoh.open(zenoh.Config.from_json5(transport.json5()))
    for path in transport.unix_sockets():
        os.chmod(path, SOCKET_MODE)
    return session


class Bus:
    """Publishers, the command queryable and the liveliness token of one rig."""

    def __init__(self, session: zenoh.Session, keys: Keys, src: str = "cyborgd") -> None:
        self.session = session
        self.keys = keys
        self.src = src
        self._seq = itertools.count(1)
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._token: zenoh.LivelinessToken | None = None
        self._queryable: zenoh.Queryable | None = None

    @classmethod
    @contextlib.contextmanager
    def open(cls, transport: Transport, keys: Keys) -> Iterator[Bus]:
        session = open_session(transport)
        bus = cls(session, keys)
        try:
            yield bus
        finally:
            bus.close()

    def close(self) -> None:
        """Undeclare everything, then close the session (clients see the token vanish)."""
        for entity in (self._token, self._queryable, *self._publishers.values()):
            if entity is not None:
                with contextlib.suppress(zenoh.ZError):
                    entity.undeclare()
        self._publishers.clear()
        self._token = self._queryable = None
        self.session.close()

    def envelope(self, msg: Message, corr: str | None = None) -> bytes:
        return encode(msg.KIND, msg.to_body(), seq=next(self._seq), src=self.src, corr=corr)

    def _publisher(self, key: str, latest_wins: bool) -> zenoh.Publisher:
        pub = self._publishers.get(key)
        if pub is None:
            cc = zenoh.CongestionControl.DROP if latest_wins else zenoh.CongestionControl.BLOCK
            pub = self.session.declare_publisher(key, congestion_control=cc)
            self._publishers[key] = pub
        return pub

    def publish(self, key: str, msg: Message, *, latest_wins: bool = False) -> None:
        """Telemetry and results; ``latest_wins`` drops rather than queues under congestion."""
        self._publisher(key, latest_wins).put(self.envelope(msg))

    def _frame_publisher(self, key: str) -> zenoh.Publisher:
        pub = self._publishers.get(key)
        if pub is None:
            pub = self.session.declare_publisher(
                key,
                encoding=zenoh.Encoding.IMAGE_JPEG,
                congestion_control=zenoh.CongestionControl.DROP,
                express=True,
            )
            self._publishers[key] = pub
        return pub

    def frame_wanted(self, key: str | None = None) -> bool:
        """Whether anyone subscribes to these live frames (no grab, no encode otherwise)."""
        return self._frame_publisher(key or self.keys.frame).matching_status.matching

    def publish_frame(self, jpeg: bytes, header: Message, key: str | None = None) -> None:
        """A live frame: the JPEG is the payload, the small header the attachment."""
        self._frame_publisher(key or self.keys.frame).put(jpeg, attachment=self.envelope(header))

    def drop_publisher(self, key: str) -> None:
        """Undeclare a stream's publisher once nobody watches it any more."""
        pub = self._publishers.pop(key, None)
        if pub is not None:
            with contextlib.suppress(zenoh.ZError):
                pub.undeclare()

    def announce(self) -> None:
        """Declare the liveliness token: from now on clients see the rig as up."""
        self._token = self.session.liveliness().declare_token(self.keys.alive)

    def declare_commands(self) -> asyncio.Queue[zenoh.Query]:
        """Declare the command queryable; queries wait in the returned queue for :meth:`serve`.

        Declared before the liveliness token, so a client that sees the rig alive can
        command it.
        """
        loop = asyncio.get_running_loop()
        queries: asyncio.Queue[zenoh.Query] = asyncio.Queue()

        def on_query(query: zenoh.Query) -> None:
            with contextlib.suppress(RuntimeError):  # loop closed during shutdown
                loop.call_soon_threadsafe(queries.put_nowait, query)

        self._queryable = self.session.declare_queryable(
            self.keys.all_commands, zenoh.handlers.Callback(on_query, indirect=False)
        )
        return queries

    async def serve(self, queries: asyncio.Queue[zenoh.Query], handler: CommandHandler) -> None:
        """Answer every command query with ``handler``'s reply, each in its own task.

        A slow command (a survey start, an archive fetch) never delays a halt.
        """
        tasks: set[asyncio.Task[None]] = set()
        try:
            while True:
                query = await queries.get()
                task = asyncio.create_task(self._answer(query, handler), name="cyborgd.bus.answer")
                tasks.add(task)
                task.add_done_callback(tasks.discard)
        finally:
            for task in tasks:
                task.cancel()

    async def _answer(self, query: zenoh.Query, handler: CommandHandler) -> None:
        with query:
            client, verb = self.keys.command_of(str(query.key_expr)) or ("", "")
            payload = query.payload.to_bytes() if query.payload is not None else b""
            try:
                reply = await handler(client, verb, payload)
            except VersionError as exc:
                query.reply_err(clip(str(exc)).encode())
                return
            except Exception:  # the handler turns known failures into Acks; this is a bug
                _LOGGER.exception("command %s from %s failed", clip(verb, 80), clip(client, 80))
                query.reply_err(b"internal error; see the daemon log")
                return
            query.reply(query.key_expr, reply)
