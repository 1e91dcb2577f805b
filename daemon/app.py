"""``cyborgd run``: the supervisor that owns the PTU, the camera, the worker and the bus.

Lifecycle: open the archive (recovering stations a crash left in progress), the bus,
the vision worker, the PTU and the camera, each entered on one AsyncExitStack; then
announce liveliness, tell systemd READY and run the service tasks in one TaskGroup until
SIGTERM/SIGINT. Shutdown runs in reverse: a running survey is cancelled (its station
marked incomplete), the head is halted before its port closes, the worker stops, the
liveliness token disappears with the session. A task that dies of a bug takes the
group down and the process exits non-zero, so systemd restarts it.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import os
import signal
import socket
import sys
import time
from collections.abc import Awaitable
from typing import TextIO

import cv2

from cyborg.protocol.envelope import MAX_MESSAGE
from cyborg.protocol.messages import Event, FrameHeader, Message, PtuState
from cyborg.protocol.redact import redact_url
from cyborg.protocol.version import BUILD, PROTOCOL_MAJOR, PROTOCOL_MINOR

from .archive import Archive
from .bus import Bus
from .camera import CameraError, open_camera
from .commands import Commands
from .config import Config
from .liveview import LiveViews, View
from .ptu import LinkState, PtuError, open_ptu
from .record import Recorder, recover_logs
from .rig import Rig
from .sdnotify import Notifier
from .survey import Survey, SurveyTelemetry
from .survey.site import Gpsd, Orientation, where
from .worker import VisionWorker

__all__ = ["run"]

_LOGGER = logging.getLogger(__name__)


class _Service:
    """The long-running tasks, sharing the rig and the bus."""

    def __init__(self, cfg: Config, bus: Bus, rig: Rig, recorder: Recorder | None) -> None:
        self.cfg, self.bus, self.rig, self.recorder = cfg, bus, rig, recorder
        quality = cfg.frames.jpeg_quality
        self.views = LiveViews(bus.keys, cfg.frames.rate, quality, bus.frame_wanted)
        self.record_view = View(bus.keys.frame, 0.0, None, quality)
        """How the session log's frames are encoded: full size, the live view's quality."""

    def event(self, level: str, text: str) -> None:
        getattr(_LOGGER, "error" if level == "error" else "info")("%s", text)
        event = Event(level, text)
        self.bus.publish(self.bus.keys.events, event)
        if self.recorder is not None:
            self.recorder.event(event)

    def publish(self, key: str, msg: Message, *, latest_wins: bool = False) -> None:
        """Onto the bus, and into the session log."""
        self.bus.publish(key, msg, latest_wins=latest_wins)
        if self.recorder is not None:
            self.recorder.message(msg)

    def _state(self) -> PtuState:
        p, ptu = self.rig.pose, self.rig.ptu
        link = ptu.state.value if isinstance(ptu.state, LinkState) else str(ptu.state)
        return PtuState(p.pan, p.tilt, p.moving, link, self.rig.control.holder)

    async def state_loop(self) -> None:
        """Poll the head at ``state_rate`` and publish; also at once on motion changes."""
        period = 1.0 / self.cfg.state_rate
        key = self.bus.keys.ptu_state
        while True:
            fresh = self.rig.ptu.last_position
            try:
                if fresh is None or time.time() - fresh.timestamp > period:
                    fresh = await self.rig.ptu.position()  # else a motion wait just read it
                self.rig.note(fresh)
            except PtuError as exc:
                _LOGGER.debug("state poll: %s", exc)
            self.publish(key, self._state(), latest_wins=True)
            self.rig.changed.clear()
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(period):
                    await self.rig.changed.wait()

    async def frame_loop(self) -> None:
        """Live frames, latest wins: grab only when a view is due and watched (or the
        session log wants one), encode each view at its size, never queue frames."""
        views = self.views
        failures = 0
        while True:
            now = time.monotonic()
            due = views.due(now)
            for key in views.dropped:
                self.bus.drop_publisher(key)
            views.dropped.clear()
            recorded = self.recorder is not None and self.recorder.frame_due()
            if due or recorded:
                try:
                    frame = await self.rig.grab()
                    failures = 0
                except CameraError as exc:
                    failures += 1
                    if failures == 1:
                        self.event("warning", f"camera: {exc}")
                    await asyncio.sleep(min(5.0, 0.5 * failures))
                    continue
                pose = frame.pose or (None, None)
                for view in [*due, self.record_view] if recorded else due:
                    encoded = await asyncio.to_thread(view.encode, frame.image)
                    if encoded is None:
                        continue
                    jpeg, width, height = encoded
                    header = FrameHeader(frame.seq, width, height, pose[0], pose[1])
                    if view is self.record_view and self.recorder is not None:
                        self.recorder.frame(jpeg, header)
                    else:
                        self.bus.publish_frame(jpeg, header, view.key)
            await asyncio.sleep(views.next_wake(time.monotonic(), cap=0.2))

    async def watchdog_loop(self, notifier: Notifier, interval: float) -> None:
        while True:
            notifier.notify("WATCHDOG=1")
            await asyncio.sleep(interval)


TEARDOWN_STEP_S = 8.0
"""Longest wait for one step of the shutdown (a survey noticing its cancellation), so the
head is halted and the archive closed well inside systemd's ``TimeoutStopSec=20``."""


async def _bounded(step: Awaitable[object], what: str) -> None:
    try:
        async with asyncio.timeout(TEARDOWN_STEP_S):
            await step
    except TimeoutError:
        _LOGGER.warning("stopping: %s did not finish in %.0f s; going on", what, TEARDOWN_STEP_S)


async def run(cfg: Config, ready_stream: TextIO | None = None) -> int:
    """Serve until SIGTERM/SIGINT; returns the exit status. The ready line (JSON) goes to
    ``ready_stream`` (default: stdout)."""
    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)
    notifier = Notifier()
    cv2.setNumThreads(1)  # the worker does the heavy lifting; leave the cores to it and zenoh
    archive = Archive(cfg.archive, cfg.rig)
    recovered = archive.open()
    await asyncio.to_thread(recover_logs, archive.root)
    if cfg.zenoh.exposed():
        _LOGGER.warning(
            "insecure = true: the bus is in clear text on %s, and anyone who reaches it can "
            "drive the PTU",
            ", ".join(cfg.zenoh.exposed()),
        )
    if cfg.zenoh.access is None and cfg.zenoh.reachable():
        _LOGGER.warning("no access list ([zenoh] users): every peer that connects may command")
    elif cfg.zenoh.access is None and cfg.zenoh.loopback():
        _LOGGER.warning(
            "no access list on loopback %s: any user of this machine may drive the PTU and "
            "feed clients fake state (a unix socket or [zenoh] users closes it: docs/security.md)",
            ", ".join(cfg.zenoh.loopback()),
        )
    async with contextlib.AsyncExitStack() as stack:
        bus = stack.enter_context(Bus.open(cfg.zenoh, cfg.keys))
        worker = await stack.enter_async_context(VisionWorker())
        ptu = open_ptu(cfg.ptu)
        rig = Rig(ptu, lambda pose: open_camera(cfg.camera.url, pose=pose, zoom=cfg.camera.zoom))
        camera = rig.camera
        await stack.enter_async_context(ptu)
        await stack.enter_async_context(camera)
        rig.note(await ptu.position())
        recorder = None
        if cfg.record.enabled:
            metadata = {
                "rig": cfg.rig,
                "build": BUILD,
                "protocol": f"{PROTOCOL_MAJOR}.{PROTOCOL_MINOR}",
                "host": socket.gethostname(),
                "camera": redact_url(cfg.camera.url),
                "ptu": redact_url(cfg.ptu),
            }
            recorder = Recorder(archive.root, metadata, cfg.record.frames)
            stack.push_async_callback(asyncio.to_thread, recorder.close)
        service = _Service(cfg, bus, rig, recorder)
        worker.on_restart = lambda text: service.event("warning", text)
        hfov = camera.hfov or cfg.camera.hfov
        if cfg.survey.zoom_on_target and not camera.has_zoom:
            raise CameraError("survey.zoom_on_target needs a camera with a zoom ([camera] zoom)")
        gpsd = Gpsd(cfg.site.gpsd) if cfg.site.gpsd else None
        survey = Survey(
            rig,
            worker,
            archive,
            cfg.survey,
            hfov=hfov,
            orientation=Orientation(cfg.site.heading, cfg.site.level),
            site=lambda: where(cfg.site, gpsd),
            telemetry=SurveyTelemetry(
                progress=lambda m: service.publish(bus.keys.progress, m),
                result=lambda m: service.publish(bus.keys.result, m),
                chip=lambda m: service.publish(bus.keys.chip, m),
                event=service.event,
            ),
        )
        stack.push_async_callback(_bounded, survey.stop("the daemon is stopping"), "survey")
        commands = Commands(
            rig,
            survey,
            archive,
            worker,
            rig_name=cfg.rig,
            encode=bus.envelope,
            announce=service.event,
            max_reply=MAX_MESSAGE - 4096,
            views=service.views,
        )
        queries = bus.declare_commands()
        bus.announce()
        notifier.notify("READY=1")
        ready = {
            "ready": True,
            "rig": cfg.rig,
            "pid": os.getpid(),
            "worker_pid": worker.pid,
            "archive": str(archive.root.resolve()),
            "recovered": recovered,
        }
        print(json.dumps(ready), file=ready_stream or sys.stdout, flush=True)
        for name in recovered:
            service.event("warning", f"station {name} was interrupted; marked incomplete")
        async with asyncio.TaskGroup() as tg:
            tasks = [
                tg.create_task(bus.serve(queries, commands.handle), name="cyborgd.bus.commands"),
                tg.create_task(service.state_loop(), name="cyborgd.ptu.state"),
                tg.create_task(service.frame_loop(), name="cyborgd.camera.frames"),
            ]
            if gpsd is not None:
                tasks.append(tg.create_task(gpsd.run(), name="cyborgd.gps.read"))
            if notifier.watchdog_interval:
                tasks.append(
                    tg.create_task(
                        service.watchdog_loop(notifier, notifier.watchdog_interval),
                        name="cyborgd.systemd.watchdog",
                    )
                )
            await stop.wait()
            _LOGGER.info("stopping")
            notifier.notify("STOPPING=1")
            for task in tasks:
                task.cancel()
    return 0
