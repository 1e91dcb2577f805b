"""``cyborg replay SESSION``: a recorded session back on the bus, at its own pace.

Reads ``session.mcap`` (the daemon's session log, :mod:`protocol.recording`) and publishes
its telemetry on the rig's keys, with the rig's liveliness token, so the keypad, the
console and scripts show the recording as they would the rig: to demonstrate them, to
test them against a real field day, or to look at a day again. It answers the read-only
commands as the rig did at that moment of the recording (``hello``, ``survey/status`` from
the telemetry replayed so far, ``archive/list`` and ``archive/get`` from the images the
recording holds) and refuses every other one with a REJECTED ack: a recording cannot move
a head. At the end it goes on answering, as the rig stood then, until stopped (or exits,
with ``--once``). A log cut short by a crash plays up to its last whole chunk.
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import contextlib
import itertools
import json
import logging
import re
import signal
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import zenoh
from mcap.exceptions import McapError
from mcap.records import Channel, Metadata, Schema
from mcap.records import Message as McapMessage
from mcap.stream_reader import StreamReader

from cyborg.protocol import recording as rec
from cyborg.protocol.envelope import decode, encode
from cyborg.protocol.errors import ProtocolError, VersionError
from cyborg.protocol.keys import Keys
from cyborg.protocol.link import open_session, send_reply, to_loop
from cyborg.protocol.messages import (
    REQUESTS,
    Ack,
    ArchiveData,
    ArchiveGet,
    ArchiveList,
    ArchiveListing,
    Chip,
    Event,
    FrameHeader,
    Hello,
    InterestResult,
    Message,
    PtuState,
    Status,
    StreamRequest,
    SurveyProgress,
    SurveyStatus,
    clip,
)
from cyborg.protocol.transport import Transport
from cyborg.protocol.version import PROTOCOL_MAJOR, PROTOCOL_MINOR

from .cli import UNREACHABLE
from .link import transport

__all__ = ["Logged", "Recorded", "log_path", "read_log", "replay", "run_replay"]

_LOGGER = logging.getLogger(__name__)

_KEYS = {
    "ptu.state": "ptu_state",
    "survey.progress": "progress",
    "survey.result": "result",
    "survey.chip": "chip",
}
_LEVELS = {v: k for k, v in rec.LOG_LEVELS.items()}
_ENDED = {"done": "awaiting-choice", "failed": "idle", "incomplete": "idle"}
"""The rig's state after a station's last progress (any other stage: surveying)."""
_DISTANCE = re.compile(r"-(\d+(?:\.\d+)?)m\Z")
"""A station's distance in its name (``st02-60m``): the recording holds it nowhere else."""
STANDING_PERIOD = 1.0
"""Seconds between the PTU states a replay at its end repeats, as the rig stood then."""


@dataclass(frozen=True)
class Logged:
    """One message of a session log."""

    topic: str
    schema: str
    log_time: int
    data: bytes


def log_path(where: Path) -> Path:
    """A session folder's log, or the file itself."""
    return where / "session.mcap" if where.is_dir() else where


def read_log(path: Path) -> tuple[dict[str, dict[str, str]], list[Logged]]:
    """(metadata by name, messages in file order), up to the last whole record: a log
    cut short by a crash reads as far as it was written."""
    metadata: dict[str, dict[str, str]] = {}
    messages: list[Logged] = []
    schemas: dict[int, str] = {}
    channels: dict[int, tuple[str, str]] = {}
    with path.open("rb") as f:
        records = StreamReader(f, skip_magic=False).records
        with contextlib.suppress(McapError, EOFError, ValueError):
            for record in records:
                if isinstance(record, Schema):
                    schemas[record.id] = record.name
                elif isinstance(record, Channel):
                    channels[record.id] = (record.topic, schemas.get(record.schema_id, ""))
                elif isinstance(record, McapMessage) and record.channel_id in channels:
                    topic, schema = channels[record.channel_id]
                    messages.append(Logged(topic, schema, record.log_time, record.data))
                elif isinstance(record, Metadata):
                    metadata[record.name] = dict(record.metadata)
    return metadata, messages


def _telemetry(messages: list[Logged]) -> Iterator[tuple[int, Message, bytes | None]]:
    """(log time, protocol message, JPEG of a live frame) in log order; a chip gets its
    image back from the message that follows it."""
    kinds = {topic: kind for kind, topic in rec.TOPICS.items()}
    images = set(rec.IMAGE_TOPICS.values())
    pending: tuple[int, Message] | None = None
    for m in messages:
        if m.topic in images and pending is not None and pending[0] == m.log_time:
            jpeg = base64.b64decode(json.loads(m.data)["data"])
            t, msg = pending
            pending = None
            if isinstance(msg, Chip):
                yield t, replace(msg, jpeg=jpeg), None
            else:
                yield t, msg, jpeg
            continue
        if pending is not None:
            yield pending[0], pending[1], None
            pending = None
        try:
            if m.topic in kinds:
                msg = rec.from_json(kinds[m.topic], m.data)
                if msg is None:
                    continue
                if m.topic in (rec.TOPICS["survey.chip"], rec.TOPICS["cam.frame"]):
                    pending = (m.log_time, msg)
                else:
                    yield m.log_time, msg, None
            elif m.topic == rec.LOG:
                doc = json.loads(m.data)
                yield m.log_time, Event(_LEVELS.get(doc["level"], "info"), doc["message"]), None
        except (ProtocolError, ValueError, KeyError):
            continue  # a message this version cannot read: skipped, as on the bus
    if pending is not None:
        yield pending[0], pending[1], None


class Recorded:
    """What the rig had said by the replay's clock (:meth:`apply` each message as it is
    published), to answer the read-only commands as it did then; the archive is what the
    recording holds: each station's mosaic and chips, under the rig's own paths."""

    def __init__(self, metadata: dict[str, dict[str, str]], messages: list[Logged]) -> None:
        self.telemetry = list(_telemetry(messages))
        self.build = metadata.get("session", {}).get("build", "")
        stations = {t: m.station for t, m, _ in self.telemetry if isinstance(m, InterestResult)}
        first = next((m for _, m, _ in self.telemetry if isinstance(m, SurveyProgress)), None)
        self.session = metadata.get("session", {}).get("session", "") or (
            first.station.split("/")[0] if first else ""
        )
        self.products: dict[str, bytes] = {}
        for m in messages:
            if m.topic == rec.MOSAIC and m.log_time in stations:
                name = stations[m.log_time].split("/", 1)[-1]
                self.products[f"{name}/mosaic.png"] = base64.b64decode(json.loads(m.data)["data"])
        for _, msg, _ in self.telemetry:
            if isinstance(msg, Chip) and msg.jpeg:
                self.products[f"{msg.station.split('/', 1)[-1]}/{msg.product}"] = msg.jpeg
        self.ptu: PtuState | None = None
        self.progress: SurveyProgress | None = None
        self.result: InterestResult | None = None
        self.last_error = ""

    def apply(self, msg: Message) -> None:
        if isinstance(msg, PtuState):
            self.ptu = msg
        elif isinstance(msg, SurveyProgress):
            self.progress = msg
            if msg.stage == "failed":
                self.last_error = f"station {msg.station} failed"
            elif msg.stage not in _ENDED:
                self.last_error = ""
        elif isinstance(msg, InterestResult):
            self.result = msg
        elif isinstance(msg, Event) and msg.level == "error" and self.last_error:
            self.last_error = msg.text  # the failed station's reason, in the rig's words

    def status(self) -> Status:
        """The rig's status as its telemetry had told it so far. The recording holds no
        choice: a station's points await one until the next station starts."""
        p = self.progress
        if p is None:
            return Status("idle", self.session, controller=self.ptu.controller if self.ptu else "")
        state = _ENDED.get(p.stage, "surveying")
        result = self.result
        waiting = (
            result
            if state == "awaiting-choice" and result and result.station == p.station
            else None
        )
        distance = _DISTANCE.search(p.station)
        return Status(
            state,
            p.station.split("/")[0],
            p.station,
            float(distance[1]) if distance else 0.0,
            self.ptu.controller if self.ptu else "",
            0,
            self.last_error,
            waiting,
        )

    def answer(self, rig: str, verb: str, payload: bytes) -> bytes:
        """The encoded reply to one command; VersionError for another protocol major."""
        try:
            env = decode(payload)
        except VersionError:
            raise
        except ProtocolError as exc:
            reply, corr = Ack("ERROR", f"{clip(verb, 64)}: {exc}"), None
        else:
            reply, corr = self._reply(rig, verb, env.kind, env.body), env.corr
        return encode(reply.KIND, reply.to_body(), seq=0, src="replay", corr=corr)

    def _reply(self, rig: str, verb: str, kind: str, body: dict) -> Message:
        """A read-only command answered, any other refused."""
        try:
            expected = REQUESTS.get(verb)
            if expected is None:
                raise ProtocolError(f"unknown command {clip(verb, 64)!r}")
            if kind != expected.KIND:
                raise ProtocolError(f"{verb} takes {expected.KIND!r}, not {clip(kind, 64)!r}")
            msg = expected.from_body(body)
        except ProtocolError as exc:
            return Ack("ERROR", f"{clip(verb, 64)}: {exc}")
        if isinstance(msg, Hello):
            build = f"replay of {self.build or 'an unknown build'}"
            return Hello(PROTOCOL_MAJOR, PROTOCOL_MINOR, build, rig)
        if isinstance(msg, SurveyStatus):
            return self.status()
        if isinstance(msg, StreamRequest):
            return Ack("REJECTED", "replay: only the recorded live view, on the rig's own key")
        if isinstance(msg, ArchiveList):
            if not msg.session:
                return ArchiveListing("", (self.session,) if self.session else ())
            if msg.session != self.session:
                return Ack("REJECTED", f"archive/list: the replay holds no session {msg.session}")
            return ArchiveListing(msg.session, tuple(sorted(self.products)))
        if isinstance(msg, ArchiveGet):
            data = self.products.get(msg.product) if msg.session == self.session else None
            if data is None:
                return Ack(
                    "REJECTED",
                    f"archive/get: {msg.session}/{msg.product} is not in the recording",
                )
            return ArchiveData(msg.session, msg.product, data)
        what = "motion" if expected.MOVES else verb
        return Ack("REJECTED", f"replay: read-only, {what} refused")


async def _serve(session: zenoh.Session, keys: Keys, recorded: Recorded) -> None:
    """Answer every command until cancelled; replies go out from a thread (a congested
    link blocks there, never the loop)."""
    queries: asyncio.Queue[zenoh.Query] = asyncio.Queue()
    queryable = session.declare_queryable(keys.all_commands, to_loop(queries.put_nowait))
    try:
        while True:
            query = await queries.get()
            _, verb = keys.command_of(str(query.key_expr)) or ("", "")
            payload = query.payload.to_bytes() if query.payload is not None else b""
            reply: bytes | None = None
            error = b""
            try:
                reply = recorded.answer(keys.rig, verb, payload)
            except VersionError as exc:
                error = clip(str(exc)).encode()
            await asyncio.to_thread(send_reply, query, reply, error)
    finally:
        queryable.undeclare()


async def replay(
    path: Path,
    transport: Transport,
    rig: str,
    speed: float = 1.0,
    *,
    ended: Callable[[int], None] | None = None,
) -> int:
    """Publish the log's telemetry on ``rig``'s keys at ``speed`` x its own pace, answering
    commands meanwhile; returns the number of messages published. With ``ended``, calls
    it with that number at the end and goes on answering until cancelled."""
    metadata, messages = read_log(path)
    recorded = Recorded(metadata, messages)
    keys = Keys(rig)
    seq = itertools.count(1)
    session = open_session(transport)
    published = 0
    try:
        async with asyncio.TaskGroup() as tg:
            server = tg.create_task(_serve(session, keys, recorded), name="cyborg.replay.serve")
            await asyncio.sleep(0)  # the commands are declared before the token
            token = session.liveliness().declare_token(keys.alive)
            await asyncio.sleep(0.5)  # let subscribers find the token and the publishers
            start, first = time.monotonic(), None
            for t, msg, jpeg in recorded.telemetry:
                first = t if first is None else first
                await asyncio.sleep(max(0.0, start + (t - first) / 1e9 / speed - time.monotonic()))
                envelope = encode(msg.KIND, msg.to_body(), seq=next(seq), src="replay", ts=t)
                recorded.apply(msg)
                if isinstance(msg, FrameHeader):
                    if jpeg is not None:
                        session.put(keys.frame, jpeg, attachment=envelope)
                elif isinstance(msg, Event):
                    session.put(keys.events, envelope)
                else:
                    session.put(getattr(keys, _KEYS[msg.KIND]), envelope)
                published += 1
            if ended is None:
                token.undeclare()
                server.cancel()
            else:
                ended(published)
                while recorded.ptu is not None:  # the head as it stood, as a rig repeats it
                    await asyncio.sleep(STANDING_PERIOD)
                    body = recorded.ptu.to_body()
                    envelope = encode(PtuState.KIND, body, seq=next(seq), src="replay")
                    session.put(keys.ptu_state, envelope)
    finally:
        session.close()
    return published


def run_replay(args: argparse.Namespace) -> int:
    # A rig that only dials is a client of the router: peers behind one router do not
    # find each other (gossip is off), so a peer's token would reach no other peer.
    link = transport(args, "client")
    path = log_path(Path(args.session))
    if not path.is_file():
        print(f"cyborg replay: no session log at {path}")
        return 2
    metadata, _ = read_log(path)
    rig = args.rig_override or metadata.get("session", {}).get("rig", "rig1")
    if args.listen:
        try:
            link = Transport("peer", listen=tuple(args.listen), insecure=args.insecure)
        except ValueError as exc:
            print(f"cyborg replay: --listen: {exc}")
            return 2

    def ended(count: int) -> None:
        print(
            f"cyborg replay: {count} messages of {path} replayed as rig {rig}; answering as "
            "it stood at the end until stopped (Ctrl-C)",
            flush=True,
        )

    async def main() -> int:
        task = asyncio.create_task(
            replay(path, link, rig, args.speed, ended=None if args.once else ended),
            name="cyborg.replay",
        )
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, task.cancel)
        try:
            count = await task
        except asyncio.CancelledError:
            return 0
        except zenoh.ZError:
            print(f"cyborg replay: cannot reach {', '.join(link.connect)}")
            return UNREACHABLE
        print(f"cyborg replay: {count} messages of {path} replayed as rig {rig}")
        return 0

    return asyncio.run(main())
