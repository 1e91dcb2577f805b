"""The session log: everything the rig publishes during a session, in one MCAP file.

``<archive>/<session>/session.mcap`` opens with the session's first station and closes
when the next session starts or the daemon stops. The event loop only enqueues (a bounded
queue, dropping and counting when full); one thread writes. Chunks are uncompressed (the
bulk is JPEG and PNG, which do not compress) and each is closed, written and fsynced at
most ``CHUNK_S`` after its first message, and at every station's start and end, so a
power cut costs at most the chunk still open. At the next start :func:`recover_logs`
rewrites a log such a cut left without its summary and footer into a complete, indexed
file holding every whole chunk. A full disk stops the log with one error and nothing
else: the survey goes on. Layout: :mod:`protocol.recording`.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import queue
import struct
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import IO, Any, NamedTuple

from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, DataEnd, Header, Metadata, Schema
from mcap.records import Message as McapMessage
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import MCAP0_MAGIC as MAGIC
from mcap.writer import CompressionType, Writer

from cyborg.protocol import recording as rec
from cyborg.protocol.messages import (
    Chip,
    Event,
    FrameHeader,
    InterestResult,
    Message,
    PtuState,
    SurveyProgress,
)

from .archive import FINAL_STATES, MANIFEST
from .vision.imageio import fsync_path

__all__ = ["DAMAGED", "FILENAME", "Recorder", "SessionLog", "recover", "recover_logs"]

_LOGGER = logging.getLogger(__name__)

FILENAME = "session.mcap"
DAMAGED = f".{FILENAME}.damaged"
"""Where recovery keeps an original it could not read to its cut (hidden: never served)."""
LIBRARY = "cyborg-astrobiologist"
CHUNK = 1 << 18
"""Largest chunk (a mosaic alone fills several)."""
CHUNK_S = 2.0
"""Longest a chunk stays open: what a power cut can cost the log."""

Item = tuple[str, str, int, bytes]
"""(topic, schema name, log time ns, JSON data)."""


class Note(NamedTuple):
    """A metadata record of the file (MCAP ``Metadata``), not a message."""

    name: str
    values: dict[str, str]


Job = Callable[[], Iterable[Item | Note]]
"""Work done in the writer thread (reading a mosaic or a manifest from disk) that yields
items."""
_END_CHUNK = "end of chunk"
"""Queued at a station boundary: close the open chunk now."""
_ENDS = ("done", *FINAL_STATES)
"""The progress stages that end a station."""


class SessionLog:
    """One MCAP file, written by its own thread from a bounded queue."""

    def __init__(self, path: Path, metadata: dict[str, str], queue_size: int = 512) -> None:
        self.path = path
        self.metadata = metadata
        self.dropped = 0
        self.failed = ""
        self._queue: queue.Queue[Item | Job | str | None] = queue.Queue(queue_size)
        self._stopping = threading.Event()
        self._thread = threading.Thread(
            target=self._write, name=f"cyborgd.record.{path.parent.name}", daemon=True
        )
        self._thread.start()

    def put(self, item: Item | Job | str) -> None:
        """Never blocks: a full queue (a stalled disk) drops the item and counts it."""
        try:
            self._queue.put_nowait(item)
        except queue.Full:
            self.dropped += 1
            if self.dropped == 1:
                _LOGGER.warning("session log %s: falling behind; dropping messages", self.path)

    def end_chunk(self) -> None:
        """Close the open chunk once what is queued is in it (a station boundary)."""
        self.put(_END_CHUNK)

    def stop(self) -> None:
        """Ask the writer to finish the file once the queue is drained (never blocks)."""
        self._stopping.set()
        with contextlib.suppress(queue.Full):
            self._queue.put_nowait(None)

    def close(self, timeout: float = 10.0) -> None:
        """Finish the file and wait for it (blocking: call it off the event loop)."""
        self.stop()
        self._thread.join(timeout)

    def _write(self) -> None:
        try:
            with self.path.open("wb") as out:
                writer = Writer(out, chunk_size=CHUNK, compression=CompressionType.NONE)
                writer.start(library=LIBRARY)
                writer.add_metadata("session", self.metadata)
                _sync(writer, out)  # the header and the metadata, before the first chunk
                channels: dict[str, int] = {}
                schemas: dict[str, int] = {}  # each registered once, whatever shares it
                due: float | None = None  # when the open chunk must close
                while True:
                    wait = None if due is None else max(0.0, due - time.monotonic())
                    try:
                        item = self._queue.get(timeout=wait)
                    except queue.Empty:
                        item = _END_CHUNK
                    if item is None:
                        break
                    if isinstance(item, str):  # a boundary: the open chunk closes now
                        due = None if due is None else time.monotonic()
                    else:
                        for one in item() if callable(item) else (item,):
                            if isinstance(one, Note):
                                writer.add_metadata(one.name, one.values)
                                continue
                            topic, schema, ns, data = one
                            if schema not in schemas:
                                schemas[schema] = writer.register_schema(
                                    schema, "jsonschema", rec.schema_data(schema)
                                )
                            if topic not in channels:
                                channels[topic] = writer.register_channel(
                                    topic, "json", schemas[schema]
                                )
                            writer.add_message(channels[topic], ns, data, ns)
                        if due is None:
                            due = time.monotonic() + CHUNK_S
                    if due is not None and time.monotonic() >= due:
                        _sync(writer, out)
                        due = None
                    if self._stopping.is_set() and self._queue.empty():
                        break
                writer.finish()
                out.flush()
                os.fsync(out.fileno())
        except OSError as exc:  # a full disk: the log stops, the rig goes on
            self.failed = exc.strerror or str(exc)
            _LOGGER.error("session log %s stopped: %s", self.path, self.failed)
            while not (self._stopping.is_set() and self._queue.empty()):
                with contextlib.suppress(queue.Empty):
                    if self._queue.get(timeout=0.5) is None:
                        return


def _sync(writer: Writer, out: IO[bytes]) -> None:
    """Close the open chunk and put it on the disk."""
    writer.flush()
    os.fsync(out.fileno())


class Recorder:
    """What the daemon publishes, into the current session's log.

    A session's log opens when the first message naming one of its stations passes (a
    station's progress); telemetry between sessions is not recorded. Live frames are
    recorded at ``frame_rate`` (0: none), whether or not anybody watches them. Where each
    station stood, and why one ended incomplete, are read from its manifest: the bus does
    not carry them.
    """

    def __init__(self, archive: Path, metadata: dict[str, str], frame_rate: float) -> None:
        self.archive = archive
        self.metadata = metadata
        self.frame_period = 1.0 / frame_rate if frame_rate > 0 else 0.0
        self.session = ""
        self.station = ""
        self.log: SessionLog | None = None
        self._next_frame = 0.0
        self._closing: list[SessionLog] = []
        self._sited: SessionLog | None = None
        """The log whose site metadata is written (at its first station)."""

    def message(self, msg: Message) -> None:
        """Telemetry as the bus carries it (progress, results, chips, the PTU state); a
        station's start and end close the open chunk."""
        station = msg.station if isinstance(msg, SurveyProgress | InterestResult | Chip) else ""
        if station:
            self._enter(station.split("/")[0])
        log = self.log
        if log is None:
            return
        ns = time.time_ns()
        if station and station != self.station:
            self.station = station
            log.end_chunk()
            log.put(self._site_job(ns, station, first=log is not self._sited))
            self._sited = log
        kind = msg.KIND
        log.put((rec.TOPICS[kind], rec.schema_name(kind), ns, rec.to_json(msg)))
        if isinstance(msg, Chip) and msg.jpeg:
            log.put((rec.IMAGE_TOPICS[kind], "foxglove.CompressedImage", ns, _image(ns, msg.jpeg)))
        elif isinstance(msg, PtuState):
            log.put(
                (rec.TF, "foxglove.FrameTransform", ns, rec.frame_transform(ns, msg.pan, msg.tilt))
            )
        elif isinstance(msg, InterestResult):
            log.put(self._mosaic_job(ns, msg))
        elif isinstance(msg, SurveyProgress) and msg.stage == "incomplete":
            log.put(self._incomplete_job(ns, msg.station))
        if isinstance(msg, InterestResult) or (
            isinstance(msg, SurveyProgress) and msg.stage in _ENDS
        ):
            log.end_chunk()

    def event(self, event: Event) -> None:
        if self.log is not None:
            self.log.put(_log_item(time.time_ns(), event))

    def frame_due(self) -> bool:
        """Whether the next live frame should be recorded (the session log's own rate)."""
        return (
            self.log is not None
            and bool(self.frame_period)
            and time.monotonic() >= self._next_frame
        )

    def frame(self, jpeg: bytes, header: FrameHeader) -> None:
        if not self.frame_due() or self.log is None:
            return
        self._next_frame = time.monotonic() + self.frame_period
        ns = time.time_ns()
        kind = header.KIND
        self.log.put((rec.TOPICS[kind], rec.schema_name(kind), ns, rec.to_json(header)))
        self.log.put((rec.IMAGE_TOPICS[kind], "foxglove.CompressedImage", ns, _image(ns, jpeg)))

    def close(self) -> None:
        """Finish every log (blocking: call it off the event loop)."""
        if self.log is not None:
            self._closing.append(self.log)
            self.log = None
        for log in self._closing:
            log.close()
        self._closing.clear()

    def _enter(self, session: str) -> None:
        if session == self.session:
            return
        if self.log is not None:
            self.log.stop()
            self._closing.append(self.log)  # waited for at close()
        self.session = session
        folder = self.archive / session
        self.log = SessionLog(folder / FILENAME, self.metadata | {"session": session})
        _LOGGER.info("session log: %s", folder / FILENAME)

    def _mosaic_job(self, ns: int, result: InterestResult) -> Job:
        """The station's mosaic and its interest points (logged with the result, at ``ns``),
        read from the archive in the writer thread."""
        folder = self.archive / result.station

        def job() -> Iterable[Item]:
            try:
                png = (folder / "mosaic.png").read_bytes()
                doc = json.loads((folder / "analysis" / "result.json").read_bytes())
                radii = {int(p["rank"]): float(p.get("radius", 0.0)) for p in doc["points"]}
            except (OSError, ValueError, KeyError) as exc:
                _LOGGER.warning("session log: no mosaic for %s: %s", result.station, exc)
                return
            yield (
                rec.MOSAIC,
                "foxglove.CompressedImage",
                ns,
                rec.compressed_image(ns, "mosaic", "png", png),
            )
            yield (
                rec.ANNOTATIONS,
                "foxglove.ImageAnnotations",
                ns,
                rec.annotations(ns, result, radii),
            )

        return job

    def _site_job(self, ns: int, station: str, *, first: bool) -> Job:
        """Where a station stood, from its manifest: a LocationFix, and at a session's
        first station the file's ``site`` metadata."""
        manifest = self.archive / station / MANIFEST

        def job() -> Iterable[Item | Note]:
            site = _manifest(manifest).get("site") or {}
            if first and site:
                yield Note("site", {"station": station} | rec.site_metadata(site))
            fix = rec.location_fix(ns, station, site)
            if fix is not None:
                yield (rec.LOCATION, "foxglove.LocationFix", ns, fix)

        return job

    def _incomplete_job(self, ns: int, station: str) -> Job:
        """A station left incomplete, with the manifest's reason (a cancel, a HALT, the
        daemon stopping): the survey announces failures, not these."""
        manifest = self.archive / station / MANIFEST

        def job() -> Iterable[Item]:
            reason = _manifest(manifest).get("reason") or "no reason recorded"
            yield _log_item(ns, Event("warning", f"station {station} incomplete: {reason}"))

        return job


def _manifest(path: Path) -> dict[str, Any]:
    """A station's manifest as far as it can be read (empty, and a warning, if not)."""
    try:
        doc = json.loads(path.read_bytes())
    except (OSError, ValueError) as exc:
        _LOGGER.warning("session log: cannot read %s: %s", path, exc)
        return {}
    return doc if isinstance(doc, dict) else {}


def _log_item(ns: int, event: Event) -> Item:
    return (rec.LOG, "foxglove.Log", ns, rec.log_entry(ns, event, "cyborgd"))


def recover_logs(archive: Path) -> list[Path]:
    """Recover every session log a crash left unfinished (no footer and magic at its end);
    returns them. Blocking: at start, before anything records."""
    done = []
    for path in sorted(archive.glob(f"*/{FILENAME}")):
        try:
            if _finished(path):
                continue
            messages, lost = recover(path)
        except OSError as exc:
            _LOGGER.error("session log %s left unfinished: %s", path, exc)
            continue
        done.append(path)
        if lost:
            _LOGGER.warning(
                "session log %s recovered with %d messages; it was damaged before its end, "
                "the original is kept as %s",
                path,
                messages,
                DAMAGED,
            )
        else:
            _LOGGER.warning("session log %s was cut short; recovered %d messages", path, messages)
    return done


def recover(path: Path) -> tuple[int, bool]:
    """Rewrite an unfinished log as a complete, indexed MCAP file: its header, metadata and
    every whole chunk whose CRC holds. Returns (messages kept, whether more than the record
    the cut left unfinished was lost: then the original stays as :data:`DAMAGED`).

    Atomic: written beside it, fsynced, renamed over it; a crash meanwhile leaves the
    original to recover at the next start."""
    size = path.stat().st_size
    aside = path.with_name(f".{path.name}.partial")
    with path.open("rb") as src, aside.open("wb") as out:
        copy = _Copy(Writer(out, chunk_size=CHUNK, compression=CompressionType.NONE))
        end = len(MAGIC) if src.read(len(MAGIC)) == MAGIC else 0
        if end:
            with contextlib.suppress(McapError, EOFError, ValueError, struct.error):
                for record in StreamReader(src, skip_magic=True, emit_chunks=True).records:
                    if isinstance(record, DataEnd):  # every chunk is in: only the summary is cut
                        end = size
                        break
                    copy.add(record)
                    end = src.tell()
        src.seek(end)
        cut = _cut_short(src.read(9), end, size)
        copy.finish({"lost_bytes": str(size - end), "messages": str(copy.messages)})
        out.flush()
        os.fsync(out.fileno())
    if not cut:
        os.replace(path, path.with_name(DAMAGED))
    os.replace(aside, path)
    fsync_path(path.parent)
    return copy.messages, not cut


class _Copy:
    """The records of an unfinished log the rig writes (header, metadata, chunks) into a
    new writer, ids renumbered as registered."""

    def __init__(self, writer: Writer) -> None:
        self.writer = writer
        self.started = False
        self.messages = 0
        self._schemas: dict[int, int] = {}
        self._channels: dict[int, int] = {}

    def add(self, record: Any) -> None:
        if isinstance(record, Header):
            self._start(record.profile, record.library)
            return
        self._start()
        if isinstance(record, Metadata):
            self.writer.add_metadata(record.name, record.metadata)
        elif isinstance(record, Chunk):
            for r in breakup_chunk(record, validate_crc=True):  # whole, or raises: all or none
                self._inner(r)

    def _inner(self, r: Any) -> None:
        if isinstance(r, Schema) and r.id not in self._schemas:
            self._schemas[r.id] = self.writer.register_schema(r.name, r.encoding, r.data)
        elif isinstance(r, Channel) and r.id not in self._channels:
            schema = self._schemas.get(r.schema_id, 0)
            self._channels[r.id] = self.writer.register_channel(
                r.topic, r.message_encoding, schema, dict(r.metadata)
            )
        elif isinstance(r, McapMessage) and r.channel_id in self._channels:
            channel = self._channels[r.channel_id]
            self.writer.add_message(channel, r.log_time, r.data, r.publish_time, r.sequence)
            self.messages += 1

    def _start(self, profile: str = "", library: str = LIBRARY) -> None:
        if not self.started:
            self.writer.start(profile, library)
            self.started = True

    def finish(self, recovery: dict[str, str]) -> None:
        """Say what recovery left out (``recovered`` metadata), then the summary and footer."""
        self._start()
        self.writer.add_metadata("recovered", recovery)
        self.writer.finish()


def _finished(path: Path) -> bool:
    with path.open("rb") as f:
        if f.seek(0, os.SEEK_END) < 2 * len(MAGIC):
            return False
        f.seek(-len(MAGIC), os.SEEK_END)
        return f.read() == MAGIC


def _cut_short(prefix: bytes, end: int, size: int) -> bool:
    """Whether all that follows the last whole record is one record the cut left
    unfinished (its opcode and a length reaching past the end of the file)."""
    if len(prefix) < 9:
        return True
    opcode, length = struct.unpack("<BQ", prefix)
    return opcode in set(Opcode) and end + 9 + length > size


def _image(ns: int, jpeg: bytes) -> bytes:
    return rec.compressed_image(ns, "camera", "jpeg", jpeg)
