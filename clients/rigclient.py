"""An asyncio client of one rig's bus: commands, telemetry, live frames, liveliness.

Depends on ``protocol`` only. zenoh callbacks run on zenoh's network thread
(``indirect=False``: no Python thread outlives the session) and only hand copied bytes
to the event loop.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import uuid
from collections.abc import Iterator
from dataclasses import dataclass

import zenoh

from protocol.envelope import decode, encode
from protocol.errors import ProtocolError
from protocol.keys import Keys
from protocol.messages import Ack, FrameHeader, Message, message_from
from protocol.transport import Transport

__all__ = ["LiveFrame", "RigClient", "RigError", "RigUnavailableError"]


class RigError(RuntimeError):
    """The rig answered with an error (or with something this client cannot read)."""


class RigUnavailableError(RigError):
    """Nobody answered: the daemon is down or unreachable."""


@dataclass(frozen=True)
class LiveFrame:
    jpeg: bytes
    header: FrameHeader
    ts: int
    """The daemon's wall clock at publication, in nanoseconds."""


class RigClient:
    def __init__(self, session: zenoh.Session, rig: str, name: str) -> None:
        self.session = session
        self.keys = Keys(rig)
        self.name = name
        self._seq = itertools.count(1)
        self._entities: list = []

    @classmethod
    @contextlib.contextmanager
    def open(cls, transport: Transport, rig: str, name: str) -> Iterator[RigClient]:
        cfg = zenoh.Config()
        for key, value in transport.json5_items():
            cfg.insert_json5(key, value)
        client = cls(zenoh.open(cfg), rig, name)
        try:
            yield client
        finally:
            client.close()

    def close(self) -> None:
        for entity in self._entities:
            with contextlib.suppress(zenoh.ZError):
                entity.undeclare()
        self._entities.clear()
        self.session.close()

    # -- commands ----------------------------------------------------------------------

    def request(self, msg: Message) -> bytes:
        return encode(
            msg.KIND, msg.to_body(), seq=next(self._seq), src=self.name, corr=uuid.uuid4().hex
        )

    async def call_raw(self, command: str, payload: bytes, timeout: float = 10.0) -> Message:
        """Send a prepared payload (tests use this to send hostile input)."""
        key = self.keys.cmd(command)

        def ask() -> list[zenoh.Reply]:
            return list(self.session.get(key, payload=payload, timeout=timeout))

        replies = await asyncio.to_thread(ask)
        if not replies:
            raise RigUnavailableError(f"no rig {self.keys.rig!r} answers {command}; is cyborgd up?")
        reply = replies[0]
        if reply.ok is None:
            raise RigError(f"{command}: {reply.err.payload.to_string()}")
        try:
            env = decode(reply.ok.payload.to_bytes())
            msg = message_from(env.kind, env.body)
        except ProtocolError as exc:
            raise RigError(f"{command}: unreadable reply: {exc}") from None
        if msg is None:
            raise RigError(f"{command}: reply of unknown kind {env.kind!r}")
        return msg

    async def call(self, command: str, msg: Message, timeout: float = 10.0) -> Message:
        return await self.call_raw(command, self.request(msg), timeout)

    async def command(self, command: str, msg: Message, timeout: float = 10.0) -> Ack:
        """A command whose answer is an Ack; a non-OK Ack raises RigError with its detail."""
        reply = await self.call(command, msg, timeout)
        if not isinstance(reply, Ack):
            raise RigError(f"{command}: expected an ack, got {reply.KIND}")
        if not reply.ok:
            raise RigError(f"{command}: {reply.result}: {reply.detail}")
        return reply

    # -- telemetry ---------------------------------------------------------------------

    def subscribe(self, key: str, maxsize: int = 0) -> asyncio.Queue[Message]:
        """Decoded messages on ``key``; with ``maxsize`` the oldest are dropped (latest wins)."""
        loop = asyncio.get_running_loop()
        queue: asyncio.Queue[Message] = asyncio.Queue()

        def push(msg: Message) -> None:
            while maxsize and queue.qsize() >= maxsize:
                queue.get_nowait()
            queue.put_nowait(msg)

        def on_sample(sample: zenoh.Sample) -> None:
            try:
                env = decode(sample.payload.to_bytes())
                msg = message_from(env.kind, env.body)
            except ProtocolError:
                return
            if msg is not None:
                with contextlib.suppress(RuntimeError):
                    loop.call_soon_threadsafe(push, msg)

        self._entities.append(
            self.session.declare_subscriber(key, zenoh.handlers.Callback(on_sample, indirect=False))
        )
        return queue

    def frames(self, maxsize: int = 1) -> asyncio.Queue[LiveFrame]:
        """Live frames, latest wins: a slow consumer sees fresh frames, never a backlog."""
        loop = asyncio.get_running_loop()
        queue: asyncio.Queue[LiveFrame] = asyncio.Queue()

        def push(frame: LiveFrame) -> None:
            while queue.qsize() >= maxsize:
                queue.get_nowait()
            queue.put_nowait(frame)

        def on_sample(sample: zenoh.Sample) -> None:
            if sample.attachment is None:
                return
            try:
                env = decode(sample.attachment.to_bytes())
                header = FrameHeader.from_body(env.body)
            except ProtocolError:
                return
            frame = LiveFrame(sample.payload.to_bytes(), header, env.ts)
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(push, frame)

        self._entities.append(
            self.session.declare_subscriber(
                self.keys.frame, zenoh.handlers.Callback(on_sample, indirect=False)
            )
        )
        return queue

    async def wait_alive(self, timeout: float = 10.0) -> None:
        """Return once the rig's liveliness token is visible (its commands are declared
        before it); RigUnavailableError after ``timeout``."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout

        def tokens() -> list:
            return list(self.session.liveliness().get(self.keys.alive, timeout=1.0))

        while not await asyncio.to_thread(tokens):
            if loop.time() > deadline:
                raise RigUnavailableError(f"rig {self.keys.rig!r} is not on the bus")
            await asyncio.sleep(0.05)

    def alive(self) -> asyncio.Queue[bool]:
        """True when the daemon's liveliness token appears, False when it goes."""
        loop = asyncio.get_running_loop()
        queue: asyncio.Queue[bool] = asyncio.Queue()

        def on_sample(sample: zenoh.Sample) -> None:
            up = sample.kind == zenoh.SampleKind.PUT
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(queue.put_nowait, up)

        self._entities.append(
            self.session.liveliness().declare_subscriber(
                self.keys.alive, zenoh.handlers.Callback(on_sample, indirect=False), history=True
            )
        )
        return queue
