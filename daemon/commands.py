"""Command dispatch: bytes from the bus in, an encoded reply out, never an exception.

Every request is decoded strictly (size, version, kind, field types and ranges) before
anything else happens; a request that fails gets an ``ERROR`` Ack saying why and never
reaches the hardware. Motion needs control (``control/take``); ``ptu/halt`` always works.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Awaitable, Callable
from typing import Any

from cyborg.protocol.envelope import decode
from cyborg.protocol.errors import ProtocolError, VersionError
from cyborg.protocol.keys import check_client
from cyborg.protocol.messages import (
    REQUESTS,
    Ack,
    ArchiveData,
    ArchiveGet,
    ArchiveList,
    ArchiveListing,
    ChooseTarget,
    Hello,
    Message,
    PtuGoto,
    PtuHalt,
    PtuHome,
    PtuJog,
    PtuLook,
    ReleaseControl,
    Request,
    Status,
    StreamRequest,
    SurveyCancel,
    SurveyStart,
    SurveyStatus,
    TakeControl,
    clip,
)
from cyborg.protocol.version import BUILD, PROTOCOL_MAJOR, PROTOCOL_MINOR

from .archive import Archive, ArchiveError
from .liveview import LiveViews
from .pointing.geometry import pixel_to_angles
from .ptu import PtuConnectionError, PtuError, PtuLimitError, PtuTimeoutError
from .rig import Rig
from .survey import Survey, SurveyBusyError, station_geometry
from .worker import VisionWorker

__all__ = ["MOTION", "Commands"]

_LOGGER = logging.getLogger(__name__)


MOTION = frozenset(verb for verb, request in REQUESTS.items() if request.MOVES)
"""Commands that need control (``Request.MOVES``)."""


class Commands:
    def __init__(
        self,
        rig: Rig,
        survey: Survey,
        archive: Archive,
        worker: VisionWorker,
        *,
        rig_name: str,
        encode: Callable[[Message, str | None], bytes],
        announce: Callable[[str, str], None],
        max_reply: int,
        views: LiveViews,
    ) -> None:
        self.rig, self.survey, self.archive, self.worker = rig, survey, archive, worker
        self.rig_name = rig_name
        self._encode = encode
        self._announce = announce
        self._max_reply = max_reply
        self.views = views
        # One handler per verb, named after it (``ptu/goto`` -> ``_ptu_goto``): a command
        # declared in protocol.messages without its handler here fails at start-up.
        self._handlers: dict[str, Callable[[Any, str], Awaitable[Message]]] = {
            verb: getattr(self, "_" + verb.replace("/", "_")) for verb in REQUESTS
        }

    async def handle(self, client: str, verb: str, payload: bytes) -> bytes:
        """Answer one command from ``client`` (its key's segment, the caller's identity).

        A request of another protocol major raises VersionError (sent as a plain-text
        error reply, readable by any version); everything else gets an Ack or a reply."""
        corr = None
        try:
            env = decode(payload)
            corr = env.corr
            check_client(client)
            expected = REQUESTS.get(verb)
            if expected is None:
                raise ProtocolError(f"unknown command {clip(verb, 64)!r}")
            if env.kind != expected.KIND:
                raise ProtocolError(f"{verb} takes {expected.KIND!r}, not {clip(env.kind, 64)!r}")
            msg = expected.from_body(env.body)
        except VersionError:
            _LOGGER.info("refused a %s request of another protocol version", clip(verb, 64))
            raise
        except ProtocolError as exc:
            _LOGGER.info("refused a malformed %s request: %s", clip(verb, 64), clip(str(exc), 200))
            return self._encode(Ack("ERROR", f"{clip(verb, 64)}: {exc}"), corr)
        if env.src != client:
            reply: Message = Ack(
                "REJECTED",
                f"{verb}: the envelope says it is from {clip(env.src, 64)!r}, the key says "
                f"{client!r}; a client speaks only for itself",
            )
        elif verb in MOTION and not self.rig.control.allows(client):
            holder = self.rig.control.holder or "nobody"
            reply = Ack(
                "REJECTED",
                f"{verb}: client {client} does not hold control (held by {holder}); "
                "send control/take first",
            )
        else:
            reply = await self._run(verb, msg, client)
        return self._encode(reply, corr)

    async def _run(self, name: str, msg: Message, src: str) -> Message:
        try:
            return await self._handlers[name](msg, src)
        except PtuLimitError as exc:  # the unit's command code is for the log, not the user
            return Ack("LIMIT", f"{name}: {exc.message}")
        except (PtuTimeoutError, TimeoutError) as exc:
            return Ack("TIMEOUT", f"{name}: {exc or 'the PTU did not answer in time'}")
        except PtuConnectionError as exc:
            return Ack("ERROR", f"{name}: PTU link down: {exc}")
        except SurveyBusyError as exc:
            return Ack("BUSY", str(exc))
        except PtuError as exc:
            return Ack("ERROR", f"{name}: {exc}")
        except (ArchiveError, ValueError) as exc:
            return Ack("REJECTED", f"{name}: {exc}")
        except OSError as exc:
            return Ack("ERROR", f"{name}: {exc.strerror or exc}")

    # -- motion ------------------------------------------------------------------------

    def _idle(self, msg: Request) -> None:
        if self.survey.running:
            raise SurveyBusyError(f"{msg.VERB}: a survey is moving the head; cancel it first")

    async def _ptu_goto(self, msg: PtuGoto, src: str) -> Message:
        self._idle(msg)
        await self.rig.ptu.move_to(msg.pan, msg.tilt, wait=False)
        self.rig.mark_moving()
        return Ack("OK", f"moving to pan {msg.pan:.3f}, tilt {msg.tilt:.3f}")

    async def _ptu_jog(self, msg: PtuJog, src: str) -> Message:
        self._idle(msg)
        here = self.rig.pose
        await self.rig.ptu.move_to(here.pan + msg.pan, here.tilt + msg.tilt, wait=False)
        self.rig.mark_moving()
        return Ack("OK", f"jogging by {msg.pan:+.3f}, {msg.tilt:+.3f}")

    async def _ptu_look(self, msg: PtuLook, src: str) -> Message:
        self._idle(msg)
        if msg.station:
            geometry = await asyncio.to_thread(station_geometry, self.archive, msg.station)
            width, height = geometry.size
            pan, tilt = geometry.to_angles(msg.u * width, msg.v * height)
        else:
            cam = self.survey.live_camera()
            a, b = pixel_to_angles(msg.u * cam.width, msg.v * cam.height, msg.pan, msg.tilt, cam)
            pan, tilt = float(a), float(b)
        await self.rig.ptu.move_to(pan, tilt, wait=False)
        self.rig.mark_moving()
        return Ack("OK", f"looking at pan {pan:.3f}, tilt {tilt:.3f}")

    async def _ptu_home(self, msg: PtuHome, src: str) -> Message:
        self._idle(msg)
        await self.rig.ptu.move_to(0.0, 0.0, wait=False)
        self.rig.mark_moving()
        return Ack("OK", "moving to pan 0, tilt 0")

    async def _ptu_halt(self, msg: PtuHalt, src: str) -> Message:
        self._announce("warning", f"HALT from {src}")  # before what it ends (a station)
        cancelled = await self.survey.cancel(f"halted by {src or 'a client'}")
        await self.rig.ptu.halt()
        return Ack("OK", "halted" + ("; the survey was cancelled" if cancelled else ""))

    async def _survey_start(self, msg: SurveyStart, src: str) -> Message:
        station = self.survey.start(msg, src)
        return Ack("OK", station)

    async def _survey_cancel(self, msg: SurveyCancel, src: str) -> Message:
        if not await self.survey.cancel(f"cancelled by {src}"):
            return Ack("REJECTED", "no survey is running")
        return Ack("OK", "survey cancelled; the station is marked incomplete")

    async def _target_choose(self, msg: ChooseTarget, src: str) -> Message:
        text = await self.survey.choose(msg, src)
        self._announce("info", f"choice by {src} at {msg.station}: {text}")
        return Ack("OK", text)

    async def _survey_status(self, msg: SurveyStatus, src: str) -> Message:
        s = self.survey
        return Status(
            s.state.value,
            s.station_id.split("/")[0],
            s.station_id,
            s.distance,
            self.rig.control.holder,
            self.worker.pid,
            s.last_error,
            s.awaiting_result,
            self._ptu_step(),
            s.aim,
        )

    def _ptu_step(self) -> float:
        """The unit's coarser position step in degrees; 0 while it has not reported."""
        try:
            info = self.rig.ptu.info
        except PtuError:
            return 0.0
        return max(info.pan.degrees_per_position, info.tilt.degrees_per_position)

    # -- control -----------------------------------------------------------------------

    async def _control_take(self, msg: TakeControl, src: str) -> Message:
        if msg.client not in ("", src):
            raise ValueError(f"{src} cannot take control for {msg.client}")
        previous = self.rig.control.take(src)
        if previous:
            self._announce("warning", f"{src} took control from {previous}")
        elif self.rig.control.holder == src:
            self._announce("info", f"{src} took control")
        return Ack("OK", f"{src} holds control" + (f" (was {previous})" if previous else ""))

    async def _control_release(self, msg: ReleaseControl, src: str) -> Message:
        if msg.client not in ("", src):
            raise ValueError(f"{src} cannot release control for {msg.client}")
        if not self.rig.control.release(src):
            return Ack("REJECTED", f"{src} does not hold control")
        self._announce("info", f"{src} released control")
        return Ack("OK", "control released")

    # -- archive and hello -------------------------------------------------------------

    async def _archive_list(self, msg: ArchiveList, src: str) -> Message:
        if not msg.session:
            return ArchiveListing("", tuple(self.archive.sessions()))
        return ArchiveListing(msg.session, tuple(self.archive.products(msg.session)))

    async def _archive_get(self, msg: ArchiveGet, src: str) -> Message:
        data = await asyncio.to_thread(self.archive.read, msg.session, msg.product, self._max_reply)
        return ArchiveData(msg.session, msg.product, data)

    async def _cam_stream(self, msg: StreamRequest, src: str) -> Message:
        return self.views.ask(msg)

    async def _hello(self, msg: Hello, src: str) -> Message:
        return Hello(PROTOCOL_MAJOR, PROTOCOL_MINOR, BUILD, self.rig_name)
