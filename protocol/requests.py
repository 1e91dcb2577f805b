"""The commands a client sends, one class per verb; everything about a command is declared
on its class (:class:`Request`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Generic, TypeVar

from .aims import parse_aim
from .base import Message, in_range
from .replies import Ack, ArchiveData, ArchiveListing, FrameStream, Status
from .settings import MAX_SETTINGS, check_setting

__all__ = [
    "REQUESTS",
    "ArchiveGet",
    "ArchiveList",
    "ChooseTarget",
    "Hello",
    "PtuGoto",
    "PtuHalt",
    "PtuHome",
    "PtuJog",
    "PtuLook",
    "ReleaseControl",
    "Request",
    "StreamRequest",
    "SurveyCancel",
    "SurveyStart",
    "SurveyStatus",
    "TakeControl",
]

R = TypeVar("R", bound=Message)


@dataclass(frozen=True)
class Request(Message, Generic[R]):
    """A command: the rig answers it on ``cyborg/<rig>/cmd/<client>/<VERB>`` with a
    ``REPLY``. Everything about a command is declared on its class, and the key space, the
    daemon's dispatch, its motion set, the access roles and the clients derive from it (add
    a command here)."""

    VERB: ClassVar[str] = ""
    REPLY: ClassVar[type[Message]] = Ack
    MOVES: ClassVar[bool] = False
    """Needs control: it moves the head (or decides where it goes)."""
    READ_ONLY: ClassVar[bool] = False
    """Changes nothing on the rig, so a viewer may send it (``protocol.access.ROLES``)."""


@dataclass(frozen=True)
class PtuGoto(Request[Ack]):
    """Point at absolute (pan, tilt) degrees; the unit's own limits are checked later."""

    KIND: ClassVar[str] = "ptu.goto"
    VERB: ClassVar[str] = "ptu/goto"
    MOVES: ClassVar[bool] = True
    pan: float
    tilt: float

    def __post_init__(self) -> None:
        in_range("pan", self.pan, -360.0, 360.0)
        in_range("tilt", self.tilt, -180.0, 180.0)


@dataclass(frozen=True)
class PtuJog(Request[Ack]):
    """Step by (pan, tilt) degrees from where the head is."""

    KIND: ClassVar[str] = "ptu.jog"
    VERB: ClassVar[str] = "ptu/jog"
    MOVES: ClassVar[bool] = True
    pan: float = 0.0
    tilt: float = 0.0

    def __post_init__(self) -> None:
        in_range("pan", self.pan, -90.0, 90.0)
        in_range("tilt", self.tilt, -90.0, 90.0)


@dataclass(frozen=True)
class PtuLook(Request[Ack]):
    """Point at what a clicked pixel shows; the rig does the geometry, so clients need no
    camera model.

    ``u``, ``v`` are fractions of the image's width and height (0..1, from the top left),
    so any display size works. With ``station`` empty the image is a live frame taken at
    (``pan``, ``tilt``), the pose in its :class:`FrameHeader`; otherwise it is that
    station's mosaic.
    """

    KIND: ClassVar[str] = "ptu.look"
    VERB: ClassVar[str] = "ptu/look"
    MOVES: ClassVar[bool] = True
    u: float
    v: float
    station: str = ""
    pan: float | None = None
    tilt: float | None = None

    def __post_init__(self) -> None:
        in_range("u", self.u, 0.0, 1.0)
        in_range("v", self.v, 0.0, 1.0)
        if not self.station and (self.pan is None or self.tilt is None):
            raise ValueError("a live-frame look needs the frame's pan and tilt")


@dataclass(frozen=True)
class PtuHalt(Request[Ack]):
    KIND: ClassVar[str] = "ptu.halt"
    VERB: ClassVar[str] = "ptu/halt"


@dataclass(frozen=True)
class PtuHome(Request[Ack]):
    KIND: ClassVar[str] = "ptu.home"
    VERB: ClassVar[str] = "ptu/home"
    MOVES: ClassVar[bool] = True


@dataclass(frozen=True)
class SurveyStart(Request[Ack]):
    """Shoot a rows × cols mosaic centred at (pan0, tilt0).

    Left out, the centre is the target chosen at the last station (the approach), else
    the last station's centre (a survey again), else the rig's configured centre: never
    wherever the head happened to stop. Other fields left out (None) take the rig's
    configured values.

    ``settings`` (2.2) change the profile's parameters for this station alone, as
    ``NAME=VALUE`` texts (``cyborgd analyze --set``); left out, the rig's configured
    ``survey.settings`` apply, and ``()`` asks for none. Their form is checked here; the rig
    checks the names and values against the profile before it moves.

    ``aim`` (2.5) is what the station is after, ``KIND[+EXCLUSION...]`` (:mod:`.aims`),
    checked here and kept in its canonical form. Left out, a station keeps the aim of the
    session's last station (a survey again, the approach's next leg), else it takes the
    rig's configured ``survey.aim``; ``any`` asks for the science's own ranking.
    """

    KIND: ClassVar[str] = "survey.start"
    VERB: ClassVar[str] = "survey/start"
    MOVES: ClassVar[bool] = True
    rows: int | None = None
    cols: int | None = None
    downsample: float | None = None
    profile: str | None = None
    pan0: float | None = None
    tilt0: float | None = None
    settings: tuple[str, ...] | None = None
    aim: str | None = None

    def __post_init__(self) -> None:
        if self.aim is not None:
            object.__setattr__(self, "aim", parse_aim(self.aim).text)
        if self.rows is not None:
            in_range("rows", self.rows, 1, 16)
        if self.cols is not None:
            in_range("cols", self.cols, 1, 32)
        if self.downsample is not None:
            in_range("downsample", self.downsample, 1.0, 16.0)
        if self.settings is not None:
            object.__setattr__(self, "settings", tuple(self.settings))
            if len(self.settings) > MAX_SETTINGS:
                raise ValueError(f"at most {MAX_SETTINGS} settings, got {len(self.settings)}")
            for item in self.settings:
                check_setting(item)


@dataclass(frozen=True)
class SurveyCancel(Request[Ack]):
    KIND: ClassVar[str] = "survey.cancel"
    VERB: ClassVar[str] = "survey/cancel"
    MOVES: ClassVar[bool] = True


@dataclass(frozen=True)
class SurveyStatus(Request[Status]):
    KIND: ClassVar[str] = "survey.status"
    VERB: ClassVar[str] = "survey/status"
    READ_ONLY: ClassVar[bool] = True
    REPLY: ClassVar[type[Message]] = Status


@dataclass(frozen=True)
class ChooseTarget(Request[Ack]):
    """The operator's choice at a station: rank 1..3, or 0 for none."""

    KIND: ClassVar[str] = "target.choose"
    VERB: ClassVar[str] = "target/choose"
    MOVES: ClassVar[bool] = True
    station: str
    rank: int

    def __post_init__(self) -> None:
        in_range("rank", self.rank, 0, 3)


@dataclass(frozen=True)
class TakeControl(Request[Ack]):
    """For the caller itself, the client named in the command's key; ``client`` may
    repeat that name and must not name another."""

    KIND: ClassVar[str] = "control.take"
    VERB: ClassVar[str] = "control/take"
    client: str = ""


@dataclass(frozen=True)
class ReleaseControl(Request[Ack]):
    """For the caller itself, the client named in the command's key; ``client`` may
    repeat that name and must not name another."""

    KIND: ClassVar[str] = "control.release"
    VERB: ClassVar[str] = "control/release"
    client: str = ""


@dataclass(frozen=True)
class ArchiveList(Request[ArchiveListing]):
    KIND: ClassVar[str] = "archive.list"
    VERB: ClassVar[str] = "archive/list"
    READ_ONLY: ClassVar[bool] = True
    REPLY: ClassVar[type[Message]] = ArchiveListing
    session: str = ""


@dataclass(frozen=True)
class ArchiveGet(Request[ArchiveData]):
    KIND: ClassVar[str] = "archive.get"
    VERB: ClassVar[str] = "archive/get"
    READ_ONLY: ClassVar[bool] = True
    REPLY: ClassVar[type[Message]] = ArchiveData
    session: str
    product: str


@dataclass(frozen=True)
class StreamRequest(Request[FrameStream]):
    """A live view that fits the link (2.1): at most ``fps`` frames a second, ``width``
    pixels wide, JPEG ``quality``. The rig publishes it on the key it answers with while
    anybody subscribes there; clients asking the same settings share one stream."""

    KIND: ClassVar[str] = "cam.stream.request"
    VERB: ClassVar[str] = "cam/stream"
    READ_ONLY: ClassVar[bool] = True
    REPLY: ClassVar[type[Message]] = FrameStream
    fps: float = 2.0
    width: int = 640
    quality: int = 70

    def __post_init__(self) -> None:
        in_range("fps", self.fps, 0.1, 30.0)
        in_range("width", self.width, 64, 4096)
        in_range("quality", self.quality, 10, 95)

    @property
    def name(self) -> str:
        """The stream's key segment, the same for the same settings.

        >>> StreamRequest(2.5, 320, 50).name
        '2.5fps-320w-q50'
        """
        return f"{self.fps:g}fps-{self.width}w-q{self.quality}"


@dataclass(frozen=True)
class Hello(Request["Hello"]):
    """Both the ``hello`` command and its answer: who the rig is and what it speaks."""

    KIND: ClassVar[str] = "hello"
    VERB: ClassVar[str] = "hello"
    READ_ONLY: ClassVar[bool] = True
    major: int
    minor: int
    build: str = ""
    rig: str = ""


Hello.REPLY = Hello

REQUESTS: dict[str, type[Request]] = {r.VERB: r for r in Request.__subclasses__()}
"""Every command by verb."""
