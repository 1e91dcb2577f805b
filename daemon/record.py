"""The session log: everything the rig publishes during a session, in one MCAP file.

``<archive>/<session>/session.mcap`` opens with the session's first station and closes
when the next session starts or the daemon stops. The event loop only enqueues (a bounded
queue, dropping and counting when full); one thread writes. Chunks are uncompressed (the
bulk is JPEG and PNG, which do not compress) and the file is flushed every second, so a
daemon killed mid-session leaves a file readable up to its last whole chunk. A full disk
stops the log with one error and nothing else: the survey goes on. Layout:
:mod:`protocol.recording`.
"""

from __future__ import annotations

import contextlib
import json
import logging
import queue
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from mcap.writer import CompressionType, Writer

from protocol import recording as rec
from protocol.messages import (
    Chip,
    Event,
    FrameHeader,
    InterestResult,
    Message,
    PtuState,
    SurveyProgress,
)

__all__ = ["FILENAME", "Recorder", "SessionLog"]

_LOGGER = logging.getLogger(__name__)

FILENAME = "session.mcap"
CHUNK = 1 << 18
"""Chunk size: a crash loses at most this much, a few seconds of the rig's telemetry with
a live frame a second (a mosaic alone fills several)."""
FLUSH_S = 1.0

Item = tuple[str, str, int, bytes]
"""(topic, schema name, log time ns, JSON data)."""
Job = Callable[[], Iterable[Item]]
"""Work done in the writer thread (reading a mosaic from disk) that yields items."""


class SessionLog:
    """One MCAP file, written by its own thread from a bounded queue."""

    def __init__(self, path: Path, metadata: dict[str, str], queue_size: int = 512) -> None:
        self.path = path
        self.metadata = metadata
        self.dropped = 0
        self.failed = ""
        self._queue: queue.Queue[Item | Job | None] = queue.Queue(queue_size)
        self._stopping = threading.Event()
        self._thread = threading.Thread(
            target=self._write, name=f"cyborgd.record.{path.parent.name}", daemon=True
        )
        self._thread.start()

    def put(self, item: Item | Job) -> None:
        """Never blocks: a full queue (a stalled disk) drops the item and counts it."""
        try:
            self._queue.put_nowait(item)
        except queue.Full:
            self.dropped += 1
            if self.dropped == 1:
                _LOGGER.warning("session log %s: falling behind; dropping messages", self.path)

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
                writer.start(library="cyborg-astrobiologist")
                writer.add_metadata("session", self.metadata)
                out.flush()  # the header and the metadata, before the first chunk
                channels: dict[str, int] = {}
                flushed = time.monotonic()
                while (item := self._queue.get()) is not None:
                    for topic, schema, ns, data in item() if callable(item) else (item,):
                        if topic not in channels:
                            channels[topic] = _channel(writer, topic, schema)
                        writer.add_message(channels[topic], ns, data, ns)
                    if time.monotonic() - flushed > FLUSH_S:
                        out.flush()
                        flushed = time.monotonic()
                    if self._stopping.is_set() and self._queue.empty():
                        break
                writer.finish()
        except OSError as exc:  # a full disk: the log stops, the rig goes on
            self.failed = exc.strerror or str(exc)
            _LOGGER.error("session log %s stopped: %s", self.path, self.failed)
            while not (self._stopping.is_set() and self._queue.empty()):
                with contextlib.suppress(queue.Empty):
                    if self._queue.get(timeout=0.5) is None:
                        return


def _channel(writer: Writer, topic: str, schema: str) -> int:
    if schema.startswith("foxglove."):
        data = rec.foxglove_schema(schema.split(".", 1)[1])
    else:
        data = json.dumps({"title": schema, "type": "object"}).encode()
    schema_id = writer.register_schema(schema, "jsonschema", data)
    return writer.register_channel(topic, "json", schema_id)


class Recorder:
    """What the daemon publishes, into the current session's log.

    A session's log opens when the first message naming one of its stations passes (a
    station's progress); telemetry between sessions is not recorded. Live frames are
    recorded at ``frame_rate`` (0: none), whether or not anybody watches them.
    """

    def __init__(self, archive: Path, metadata: dict[str, str], frame_rate: float) -> None:
        self.archive = archive
        self.metadata = metadata
        self.frame_period = 1.0 / frame_rate if frame_rate > 0 else 0.0
        self.session = ""
        self.log: SessionLog | None = None
        self._next_frame = 0.0
        self._closing: list[SessionLog] = []

    def message(self, msg: Message) -> None:
        """Telemetry as the bus carries it (progress, results, chips, the PTU state)."""
        station = getattr(msg, "station", "")
        if isinstance(msg, SurveyProgress | InterestResult | Chip) and station:
            self._enter(station.split("/")[0])
        log = self.log
        if log is None:
            return
        ns = time.time_ns()
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

    def event(self, event: Event) -> None:
        if self.log is not None:
            ns = time.time_ns()
            self.log.put((rec.LOG, "foxglove.Log", ns, rec.log_entry(ns, event, "cyborgd")))

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


def _image(ns: int, jpeg: bytes) -> bytes:
    return rec.compressed_image(ns, "camera", "jpeg", jpeg)
