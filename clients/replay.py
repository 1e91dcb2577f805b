"""``cyborg replay SESSION``: a recorded session back on the bus, at its own pace.

Reads ``session.mcap`` (the daemon's session log, :mod:`protocol.recording`) and publishes
its telemetry on the rig's keys, with the rig's liveliness token, so the keypad, the
console and scripts show the recording as they would the rig: to demonstrate them, to
test them against a real field day, or to look at a day again. Commands are not answered
(a recording cannot move a head). A log cut short by a crash plays up to its last whole
chunk.
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import contextlib
import itertools
import json
import signal
import time
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

from mcap.exceptions import McapError
from mcap.records import Channel, Metadata, Schema
from mcap.records import Message as McapMessage
from mcap.stream_reader import StreamReader

from cyborg.protocol import recording as rec
from cyborg.protocol.envelope import encode
from cyborg.protocol.errors import ProtocolError
from cyborg.protocol.keys import Keys
from cyborg.protocol.link import open_session
from cyborg.protocol.messages import Chip, Event, FrameHeader, Message
from cyborg.protocol.transport import Transport

from .link import transport

__all__ = ["Logged", "log_path", "read_log", "replay", "run_replay"]

_KEYS = {
    "ptu.state": "ptu_state",
    "survey.progress": "progress",
    "survey.result": "result",
    "survey.chip": "chip",
}
_LEVELS = {v: k for k, v in rec.LOG_LEVELS.items()}


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


async def replay(path: Path, transport: Transport, rig: str, speed: float = 1.0) -> int:
    """Publish the log's telemetry on ``rig``'s keys at ``speed`` x its own pace; returns
    the number of messages published."""
    _, messages = read_log(path)
    keys = Keys(rig)
    seq = itertools.count(1)
    session = open_session(transport)
    published = 0
    try:
        token = session.liveliness().declare_token(keys.alive)
        await asyncio.sleep(0.5)  # let subscribers find the token and the publishers
        start, first = time.monotonic(), None
        for t, msg, jpeg in _telemetry(messages):
            first = t if first is None else first
            await asyncio.sleep(max(0.0, start + (t - first) / 1e9 / speed - time.monotonic()))
            envelope = encode(msg.KIND, msg.to_body(), seq=next(seq), src="replay", ts=t)
            if isinstance(msg, FrameHeader):
                if jpeg is not None:
                    session.put(keys.frame, jpeg, attachment=envelope)
            elif isinstance(msg, Event):
                session.put(keys.events, envelope)
            else:
                session.put(getattr(keys, _KEYS[msg.KIND]), envelope)
            published += 1
        token.undeclare()
    finally:
        session.close()
    return published


def run_replay(args: argparse.Namespace) -> int:
    link = transport(args, "peer")
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

    async def main() -> int:
        task = asyncio.create_task(replay(path, link, rig, args.speed), name="cyborg.replay")
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, task.cancel)
        with contextlib.suppress(asyncio.CancelledError):
            count = await task
            print(f"cyborg replay: {count} messages of {path} replayed as rig {rig}")
        return 0

    return asyncio.run(main())
