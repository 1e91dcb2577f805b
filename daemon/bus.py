"""The daemon's side of the zenoh bus, bridged into asyncio.

The session and the command queryable's hand-off to the event loop come from
:mod:`protocol.link`.

Nothing sent from here may block the event loop, because a HALT waits behind it. A
message sent with zenoh's ``BLOCK`` congestion control waits, when one peer stops
reading (a viewer whose radio link stalls), until there is room or until zenoh gives
that link up (``wait_before_close``, 5 s). So:

- telemetry that may be lost (the PTU's state, live frames) is put with ``DROP`` from
  the loop: zenoh drops it for the congested peer alone;
- what must arrive (progress, results, chips, events) goes through the :class:`Outbox`:
  sent in order from its own thread, at most :data:`OUTBOX_BOUND` waiting per key; past
  that a key's oldest waiting message is dropped and counted in a warning (the archive
  and the session log keep every one of them, for ``archive/get`` and replay);
- command replies are sent from a thread pool (zenoh-python releases the GIL while it
  waits), so a querier that stopped reading delays its own reply only.
"""

from __future__ import annotations

import asyncio
import collections
import contextlib
import itertools
import logging
import threading
from collections.abc import Awaitable, Callable, Iterator
from concurrent.futures import ThreadPoolExecutor

import zenoh

from cyborg.protocol.envelope import MAX_MESSAGE, encode
from cyborg.protocol.errors import VersionError
from cyborg.protocol.keys import Keys
from cyborg.protocol.link import open_session, send_reply, to_loop
from cyborg.protocol.messages import Message, clip
from cyborg.protocol.transport import Transport

__all__ = ["OUTBOX_BOUND", "Bus", "CommandHandler", "Outbox"]

_LOGGER = logging.getLogger(__name__)

CommandHandler = Callable[[str, str, bytes], Awaitable[bytes]]
"""(caller, verb, request payload) -> reply payload (an encoded envelope). The caller is the
``<client>`` segment of the key. A VersionError raised is sent as a plain-text error
reply, which a peer of any protocol version can read."""


OUTBOX_BOUND = 256
"""Reliable messages of one key waiting to be sent; past it the oldest are dropped."""
TELEMETRY = zenoh.Priority.DATA_LOW
"""The priority of what the loop puts itself (state, frames). zenoh queues each priority
of a link apart, and a ``BLOCK`` message waiting on a congested link holds its priority's
queue: a ``DROP`` message of the same priority would wait behind it, on the loop."""
REPLY_THREADS = 16
"""Replies being sent at once; each waits at most zenoh's ``wait_before_close``."""


class Outbox:
    """The reliable publications, put in the daemon's order by their own thread.

    :meth:`send` never blocks: a peer that stopped reading blocks this thread (until zenoh
    closes that peer's link), not the caller. One thread keeps the order across keys (a
    station's last progress before its result). At most ``bound`` messages of one key
    wait; past that its oldest waiting message is dropped, and the drops are logged once
    the box drains.
    """

    def __init__(self, bound: int = OUTBOX_BOUND) -> None:
        self.bound = bound
        self.dropped = 0
        self._waiting: collections.deque[tuple[zenoh.Publisher, str, bytes]] = collections.deque()
        self._count: collections.Counter[str] = collections.Counter()
        self._ready = threading.Condition()
        self._closing = False
        self._thread = threading.Thread(target=self._run, name="cyborgd-outbox")
        self._thread.start()

    def send(self, publisher: zenoh.Publisher, key: str, payload: bytes) -> None:
        with self._ready:
            if self._count[key] >= self.bound:
                oldest = next(i for i, item in enumerate(self._waiting) if item[1] == key)
                del self._waiting[oldest]
                self._count[key] -= 1
                self.dropped += 1
            self._waiting.append((publisher, key, payload))
            self._count[key] += 1
            self._ready.notify()

    def close(self, timeout: float = 6.0) -> None:
        """Send what waits (each at most zenoh's link timeout), then stop the thread."""
        with self._ready:
            self._closing = True
            self._ready.notify()
        self._thread.join(timeout)

    def _run(self) -> None:
        reported = 0
        while True:
            with self._ready:
                while not self._waiting and not self._closing:
                    self._ready.wait()
                if not self._waiting:
                    return
                publisher, key, payload = self._waiting.popleft()
                self._count[key] -= 1
                drained, dropped = not self._waiting, self.dropped
            try:
                publisher.put(payload)
            except zenoh.ZError as exc:
                _LOGGER.debug("%s: not sent: %s", key, exc)
            if drained and dropped > reported:
                _LOGGER.warning(
                    "%d reliable messages dropped: a subscriber was not reading "
                    "(the archive and the session log keep them)",
                    dropped - reported,
                )
                reported = dropped


class Bus:
    """Publishers, the command queryable and the liveliness token of one rig."""

    def __init__(self, session: zenoh.Session, keys: Keys, src: str = "cyborgd") -> None:
        self.session = session
        self.keys = keys
        self.src = src
        self._seq = itertools.count(1)
        self._publishers: dict[str, zenoh.Publisher] = {}
        self._outbox = Outbox()
        self._replies = ThreadPoolExecutor(REPLY_THREADS, thread_name_prefix="cyborgd-reply")
        self._token: zenoh.LivelinessToken | None = None
        self._oversize_warned = False
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
        """Send what waits, undeclare everything, then close the session (clients see the
        token vanish)."""
        self._outbox.close()
        self._replies.shutdown(wait=True)
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
            if latest_wins:
                pub = self.session.declare_publisher(
                    key, congestion_control=zenoh.CongestionControl.DROP, priority=TELEMETRY
                )
            else:
                pub = self.session.declare_publisher(
                    key, congestion_control=zenoh.CongestionControl.BLOCK
                )
            self._publishers[key] = pub
        return pub

    def publish(self, key: str, msg: Message, *, latest_wins: bool = False) -> None:
        """Telemetry and results, never blocking: ``latest_wins`` is dropped for a congested
        peer; the rest waits in the key's :class:`Outbox`."""
        payload = self.envelope(msg)
        if latest_wins:
            self._publisher(key, True).put(payload)
            return
        self._outbox.send(self._publisher(key, False), key, payload)

    def _frame_publisher(self, key: str) -> zenoh.Publisher:
        pub = self._publishers.get(key)
        if pub is None:
            pub = self.session.declare_publisher(
                key,
                encoding=zenoh.Encoding.IMAGE_JPEG,
                congestion_control=zenoh.CongestionControl.DROP,
                priority=TELEMETRY,
                express=True,
            )
            self._publishers[key] = pub
        return pub

    def frame_wanted(self, key: str | None = None) -> bool:
        """Whether anyone subscribes to these live frames (no grab, no encode otherwise)."""
        return self._frame_publisher(key or self.keys.frame).matching_status.matching

    def publish_frame(self, jpeg: bytes, header: Message, key: str | None = None) -> None:
        """A live frame: the JPEG is the payload, the small header the attachment. One over
        the protocol's size limit is not sent (every link would drop it): a warning, once."""
        if len(jpeg) > MAX_MESSAGE:
            if not self._oversize_warned:
                self._oversize_warned = True
                _LOGGER.warning(
                    "live frame of %d bytes is over the %d-byte message limit: not sent "
                    "(ask for a smaller view: cam/stream, or lower [frames] jpeg_quality)",
                    len(jpeg),
                    MAX_MESSAGE,
                )
            return
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
        queries: asyncio.Queue[zenoh.Query] = asyncio.Queue()
        self._queryable = self.session.declare_queryable(
            self.keys.all_commands, to_loop(queries.put_nowait)
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
        """Run the handler on the loop; the reply goes out from a thread (and the query,
        released there, sends its final message there too)."""
        client, verb = self.keys.command_of(str(query.key_expr)) or ("", "")
        size = len(query.payload) if query.payload is not None else 0
        reply: bytes | None = None
        error = b""
        if size > MAX_MESSAGE:  # refused before it is copied
            error = f"request of {size} bytes is over the {MAX_MESSAGE}-byte limit".encode()
        else:
            payload = query.payload.to_bytes() if query.payload is not None else b""
            try:
                reply = await handler(client, verb, payload)
            except VersionError as exc:
                error = clip(str(exc)).encode()
            except Exception:  # the handler turns known failures into Acks; this is a bug
                _LOGGER.exception("command %s from %s failed", clip(verb, 80), clip(client, 80))
                error = b"internal error; see the daemon log"
        loop = asyncio.get_running_loop()
        await loop.run_in_executor(self._replies, send_reply, query, reply, error)
