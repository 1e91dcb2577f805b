"""An asyncio client of one rig's bus: commands, telemetry, live frames, liveliness.

Depends on ``protocol`` only. zenoh callbacks (:func:`protocol.link.to_loop`) only hand
copied bytes (or a liveliness change) to the event loop.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import logging
import typing
import uuid
from collections.abc import AsyncIterator, Callable, Collection, Iterator
from dataclasses import dataclass
from typing import TypeVar

import zenoh

from cyborg.protocol.envelope import MAX_MESSAGE, decode, encode
from cyborg.protocol.errors import ProtocolError
from cyborg.protocol.keys import Keys, check_client
from cyborg.protocol.link import open_session, to_loop
from cyborg.protocol.messages import (
    Ack,
    FrameHeader,
    InterestResult,
    Message,
    ReleaseControl,
    Request,
    StreamRequest,
    SurveyCancel,
    SurveyProgress,
    SurveyStart,
    SurveyStatus,
    TakeControl,
    message_from,
)
from cyborg.protocol.transport import Transport

R = TypeVar("R", bound=Message)
_LOGGER = logging.getLogger(__name__)

__all__ = [
    "ControlHeldError",
    "LiveFrame",
    "RigClient",
    "RigError",
    "RigRefusedError",
    "RigUnavailableError",
    "run_station",
    "until_stage",
]


class RigError(RuntimeError):
    """The rig answered with an error (or with something this client cannot read)."""


class RigUnavailableError(RigError):
    """Nobody answered: the daemon is down or unreachable."""


class RigRefusedError(RigError):
    """The rig answered a command with a non-OK ack."""

    def __init__(self, command: str, ack: Ack) -> None:
        super().__init__(f"{command}: {ack.result}: {ack.detail.removeprefix(f'{command}: ')}")
        self.ack = ack


class ControlHeldError(RigError):
    """Another client holds control; taking it over must be asked for."""

    def __init__(self, holder: str) -> None:
        super().__init__(f"control is held by {holder}")
        self.holder = holder


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
        self.name = check_client(name)
        self._seq = itertools.count(1)
        self._entities: list = []
        self.undo: dict[str, Request] = {}
        """What :meth:`rollback` sends, by verb: the release of the control this client
        took, the cancel of the survey it is running."""

    @classmethod
    @contextlib.contextmanager
    def open(cls, transport: Transport, rig: str, name: str) -> Iterator[RigClient]:
        Keys(rig), check_client(name)  # refuse bad names before opening anything
        client = cls(open_session(transport), rig, name)
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

    async def call_raw(
        self, verb: str, payload: bytes, timeout: float = 10.0, *, client: str | None = None
    ) -> Message:
        """Send a prepared payload as ``client`` (default: this client); tests use this to
        send hostile input."""
        key = self.keys.cmd(self.name if client is None else client, verb)

        def ask() -> list[zenoh.Reply]:
            return list(self.session.get(key, payload=payload, timeout=timeout))

        replies = await asyncio.to_thread(ask)
        if not replies:
            raise RigUnavailableError(
                f"no rig {self.keys.rig!r} answers {verb}; is cyborgd up, and may "
                f"{self.name} send it?"
            )
        reply = replies[0]
        if reply.ok is None:
            raise RigError(f"{verb}: {reply.err.payload.to_string()}")
        try:
            env = decode(reply.ok.payload.to_bytes())
            msg = message_from(env.kind, env.body)
        except ProtocolError as exc:
            raise RigError(f"{verb}: unreadable reply: {exc}") from None
        if msg is None:
            raise RigError(f"{verb}: reply of unknown kind {env.kind!r}")
        return msg

    async def call(self, msg: Request, timeout: float = 10.0) -> Message:
        """Send a command; its reply whatever it is (a refusing Ack included). One over the
        protocol's size limit is refused here: the rig's link would drop it unanswered."""
        payload = self.request(msg)
        if len(payload) > MAX_MESSAGE:
            raise ValueError(
                f"{msg.VERB}: {len(payload)} bytes, over the protocol's {MAX_MESSAGE}-byte limit"
            )
        return await self.call_raw(msg.VERB, payload, timeout)

    async def command(self, msg: Request[R], timeout: float = 10.0) -> R:
        """Send a command and return its reply, of the kind the request declares; a non-OK
        Ack raises RigRefusedError with its detail."""
        reply = await self.call(msg, timeout)
        if isinstance(reply, Ack) and not reply.ok:
            raise RigRefusedError(msg.VERB, reply)
        if not isinstance(reply, msg.REPLY):
            raise RigError(f"{msg.VERB}: expected {msg.REPLY.KIND}, got {reply.KIND}")
        return typing.cast(R, reply)

    async def ensure_control(self, take_over: bool = False) -> bool:
        """Hold control before a motion command: take it when nobody holds it, or from
        another client only with ``take_over`` (never silently). True if it was taken."""
        status = await self.command(SurveyStatus())
        if status.controller == self.name:
            return False
        if status.controller and not take_over:
            raise ControlHeldError(status.controller)
        await self.command(TakeControl())
        self.undo[ReleaseControl.VERB] = ReleaseControl()
        return True

    async def rollback(self, timeout: float = 5.0) -> list[str]:
        """Undo what this client started and took, newest first, for a script stopped
        half-way (a survey left running would keep the head and the control); returns
        the details of what the rig undid. Refusals and silence are skipped."""
        done = []
        while self.undo:
            verb, msg = self.undo.popitem()
            try:
                done.append((await self.command(msg, timeout)).detail)
            except RigError as exc:
                _LOGGER.debug("%s not undone: %s", verb, exc)
        return done

    # -- telemetry ---------------------------------------------------------------------

    def subscribe(self, key: str, kind: type[R], maxsize: int = 0) -> asyncio.Queue[R]:
        """Messages of ``kind`` on ``key`` (anything else there is dropped); with
        ``maxsize`` the oldest are dropped (latest wins)."""
        queue: asyncio.Queue[R] = asyncio.Queue()

        def push(msg: R) -> None:
            while maxsize and queue.qsize() >= maxsize:
                queue.get_nowait()
            queue.put_nowait(msg)

        def pick(sample: zenoh.Sample) -> R | None:
            try:
                env = decode(sample.payload.to_bytes())
                msg = message_from(env.kind, env.body)
            except ProtocolError:
                return None
            return msg if isinstance(msg, kind) else None

        self._entities.append(self.session.declare_subscriber(key, to_loop(push, pick)))
        return queue

    async def stream(self, fps: float, width: int, quality: int = 70) -> str:
        """Ask the rig for a live view that fits a thin link; returns its key (for
        :meth:`frames` and :meth:`frame_subscriber`)."""
        return (await self.command(StreamRequest(fps, width, quality))).key

    def frames(self, maxsize: int = 1, key: str | None = None) -> asyncio.Queue[LiveFrame]:
        """Live frames (the default view, or a :meth:`stream`), latest wins: a slow
        consumer sees fresh frames, never a backlog."""
        queue: asyncio.Queue[LiveFrame] = asyncio.Queue()

        def push(frame: LiveFrame) -> None:
            while queue.qsize() >= maxsize:
                queue.get_nowait()
            queue.put_nowait(frame)

        self._entities.append(self.frame_subscriber(push, key))
        return queue

    def frame_subscriber(
        self, on_frame: Callable[[LiveFrame], None], key: str | None = None
    ) -> zenoh.Subscriber:
        """Call ``on_frame`` on the loop with each live frame until the returned subscriber
        is undeclared; the daemon grabs frames only while somebody subscribes."""

        def pick(sample: zenoh.Sample) -> LiveFrame | None:
            if sample.attachment is None:
                return None
            try:
                env = decode(sample.attachment.to_bytes())
                header = FrameHeader.from_body(env.body)
            except ProtocolError:
                return None
            return LiveFrame(sample.payload.to_bytes(), header, env.ts)

        return self.session.declare_subscriber(key or self.keys.frame, to_loop(on_frame, pick))

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
        queue: asyncio.Queue[bool] = asyncio.Queue()
        self._entities.append(self._liveliness(queue.put_nowait))
        return queue

    def _liveliness(self, on_change: Callable[[bool], None]) -> zenoh.Subscriber:
        """Call ``on_change`` on the loop with True when the rig's liveliness token is
        (or becomes) visible, False when it goes."""

        def pick(sample: zenoh.Sample) -> bool:
            return sample.kind == zenoh.SampleKind.PUT

        return self.session.liveliness().declare_subscriber(
            self.keys.alive, to_loop(on_change, pick), history=True
        )

    @contextlib.asynccontextmanager
    async def on_bus(self, wait: float = 10.0) -> AsyncIterator[None]:
        """Wait up to ``wait`` s for the rig (:meth:`wait_alive`), then run the block while
        its liveliness token stays: when it goes (at once if the daemon dies, after zenoh's
        lease if its link goes silent) the block is cancelled and RigUnavailableError
        raised, instead of waiting out a command's timeout."""
        task = asyncio.current_task()
        assert task is not None
        lost = False

        def on_change(up: bool) -> None:
            nonlocal lost
            if not up and not lost:
                lost = True
                task.cancel()

        watch = self._liveliness(on_change)  # before the wait: a loss in between counts
        try:
            await self.wait_alive(wait)
            yield
        except asyncio.CancelledError:
            if lost and task.uncancel() == 0:
                raise RigUnavailableError(f"rig {self.keys.rig!r} left the bus") from None
            raise
        finally:
            lost = True  # disarmed: the block is over
            with contextlib.suppress(zenoh.ZError):
                watch.undeclare()


async def until_stage(
    progress: asyncio.Queue[SurveyProgress],
    station: str,
    stages: Collection[str],
    timeout: float = 120.0,
) -> SurveyProgress:
    """The first progress of ``station`` at one of ``stages`` (a subscription made before
    the station started, so none is missed); TimeoutError after ``timeout``."""
    async with asyncio.timeout(timeout):
        while True:
            p = await progress.get()
            if p.station == station and p.stage in stages:
                return p


async def run_station(
    client: RigClient,
    progress: asyncio.Queue[SurveyProgress],
    results: asyncio.Queue[InterestResult],
    request: SurveyStart,
    *,
    timeout: float = 300.0,
    on_progress: Callable[[SurveyProgress], None] | None = None,
) -> InterestResult:
    """Start a survey and follow it to its result; raise RigError if it fails.

    ``progress`` and ``results`` are subscriptions made before the start, so nothing
    published in between is missed. If the caller is cancelled meanwhile, the station
    may go on: ``client.undo`` keeps its cancel for :meth:`RigClient.rollback`.
    """
    client.undo[SurveyCancel.VERB] = SurveyCancel()  # an interrupted start may still land
    over = True
    try:
        station = (await client.command(request)).detail
        async with asyncio.timeout(timeout):
            while True:
                p = await progress.get()
                if p.station != station:
                    continue
                if on_progress is not None:
                    on_progress(p)
                if p.stage in ("failed", "incomplete"):
                    raise RigError(f"station {station} {p.stage}")
                if p.stage == "done":
                    break
            while True:
                result = await results.get()
                if result.station == station:
                    return result
    except asyncio.CancelledError:
        over = False
        raise
    finally:
        if over:
            client.undo.pop(SurveyCancel.VERB, None)
