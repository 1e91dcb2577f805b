"""The rig's answers and telemetry: acks, the PTU's state, survey progress and results,
live-frame headers, chips, status and archive data."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from .base import RESULTS, Message, clip

__all__ = [
    "Ack",
    "ArchiveData",
    "ArchiveListing",
    "Chip",
    "Event",
    "FrameHeader",
    "FrameStream",
    "InterestPoint",
    "InterestResult",
    "PtuState",
    "Status",
    "SurveyProgress",
]


@dataclass(frozen=True)
class Ack(Message):
    """Every command's answer: ``result`` in RESULTS, ``detail`` for humans."""

    KIND: ClassVar[str] = "ack"
    result: str
    detail: str = ""

    def __post_init__(self) -> None:
        if self.result not in RESULTS:
            raise ValueError(f"result {self.result!r} not one of {', '.join(RESULTS)}")
        object.__setattr__(self, "detail", clip(self.detail))

    @property
    def ok(self) -> bool:
        return self.result == "OK"


@dataclass(frozen=True)
class PtuState(Message):
    """Where the head points (degrees), whether it moves, its link, who holds control."""

    KIND: ClassVar[str] = "ptu.state"
    MAX_STEP: ClassVar[float] = 0.06
    """Degrees: the coarsest position step of a supported unit (a PTU-46 D46-17's 185.1428″
    is 0.0514°), for a rig older than 2.3, whose status does not say its own
    (``Status.ptu_step``); ``tests/ptu`` holds every emulated model to this bound."""
    pan: float
    tilt: float
    moving: bool
    link: str = "ready"
    controller: str = ""


@dataclass(frozen=True)
class SurveyProgress(Message):
    KIND: ClassVar[str] = "survey.progress"
    station: str
    stage: str
    done: int = 0
    total: int = 0
    eta_s: float | None = None


@dataclass(frozen=True)
class InterestPoint(Message):
    KIND: ClassVar[str] = "interest.point"
    rank: int
    x: float
    y: float
    score: float
    pan: float
    tilt: float
    why: str = ""
    azimuth: float | None = None
    """True azimuth (degrees from north) when the rig knows its heading (2.1)."""
    elevation: float | None = None
    """Degrees above the horizon, the head's level offset applied (2.1)."""
    radius_deg: float | None = None
    """The target's angular radius, degrees (2.1): how big it is, not just where."""
    novelty: float | None = None
    """How new the point is against what the session's earlier stations saw at its place and
    scale (2.1), 0 to 1: 0 when an earlier station ranked it, else the share of its contrast
    against its surround that no earlier station covering and resolving that place showed; 1
    when none did. Above 0.5 the explanation says "new since <first station>", else where it
    was seen ("#1 at st01-300m", "seen at st01-300m"). None at a session's first station and
    for a point that is no target."""
    target: bool = True
    """False when the point's score cannot be told from the view's background (2.4): it is
    kept and marked, reported as "no further target", with no chip and no choice."""


@dataclass(frozen=True)
class InterestResult(Message):
    KIND: ClassVar[str] = "survey.result"
    station: str
    points: tuple[InterestPoint, ...] = ()
    width: int = 0
    height: int = 0
    aim: str = ""
    """The aim of study the station sought (2.5, ``protocol.aims``, canonical form): its
    points are ranked for it. Empty: an older rig, whose ranking was the science's own."""


@dataclass(frozen=True)
class Event(Message):
    KIND: ClassVar[str] = "event"
    level: str
    text: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "text", clip(self.text))


@dataclass(frozen=True)
class FrameHeader(Message):
    """The attachment of a live frame; the payload is the JPEG itself."""

    KIND: ClassVar[str] = "cam.frame"
    seq: int
    width: int
    height: int
    pan: float | None = None
    tilt: float | None = None


@dataclass(frozen=True)
class FrameStream(Message):
    """The answer to ``cam/stream``: where the asked-for live view is published."""

    KIND: ClassVar[str] = "cam.stream"
    key: str
    fps: float
    width: int
    quality: int


@dataclass(frozen=True)
class Chip(Message):
    """A full-resolution frame taken pointing at one interest point."""

    KIND: ClassVar[str] = "survey.chip"
    station: str
    rank: int
    pan: float
    tilt: float
    product: str
    jpeg: bytes = b""


@dataclass(frozen=True)
class Status(Message):
    """The answer to ``survey/status``: what the rig is doing and who drives it."""

    KIND: ClassVar[str] = "status"
    state: str
    session: str = ""
    station: str = ""
    distance_m: float = 0.0
    controller: str = ""
    worker_pid: int = 0
    last_error: str = ""
    result: InterestResult | None = None
    """The station's result while it awaits a choice (2.1): a client that starts then
    shows the points without waiting for the next survey."""
    ptu_step: float = 0.0
    """Degrees: the unit's coarser position step, as it reported its resolution (2.3); a
    head standing still this close to a target is there. 0: an older rig."""
    aim: str = ""
    """The aim of study a station started without one takes (2.5): the session's last
    station's, else the rig's configured ``survey.aim``. Empty: an older rig."""


@dataclass(frozen=True)
class ArchiveListing(Message):
    """Sessions (when ``session`` is empty) or one session's products, as relative paths."""

    KIND: ClassVar[str] = "archive.listing"
    session: str
    items: tuple[str, ...] = ()


@dataclass(frozen=True)
class ArchiveData(Message):
    KIND: ClassVar[str] = "archive.data"
    session: str
    product: str
    data: bytes
