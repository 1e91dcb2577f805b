"""Frozen message dataclasses, one per kind, with tolerant but strict decoding.

Tolerant: unknown fields are ignored and fields missing from an older peer take their
defaults. Strict: a present field of the wrong type, a non-finite number or an
out-of-range value raises :class:`~protocol.errors.InvalidFieldError`, so malformed
commands never reach the hardware.
"""

from __future__ import annotations

import math
import types
import typing
from dataclasses import MISSING, asdict, dataclass, fields
from typing import Any, ClassVar, Generic, Self, TypeVar

from .errors import DecodeError, InvalidFieldError

__all__ = [
    "MAX_SETTINGS",
    "MAX_TEXT",
    "MESSAGES",
    "REQUESTS",
    "RESULTS",
    "Ack",
    "ArchiveData",
    "ArchiveGet",
    "ArchiveList",
    "ArchiveListing",
    "Chip",
    "ChooseTarget",
    "Event",
    "FrameHeader",
    "FrameStream",
    "Hello",
    "InterestPoint",
    "InterestResult",
    "Message",
    "PtuGoto",
    "PtuHalt",
    "PtuHome",
    "PtuJog",
    "PtuLook",
    "PtuState",
    "ReleaseControl",
    "Request",
    "Status",
    "StreamRequest",
    "SurveyCancel",
    "SurveyProgress",
    "SurveyStart",
    "SurveyStatus",
    "TakeControl",
    "check_setting",
    "clip",
    "message_from",
]

RESULTS = ("OK", "REJECTED", "LIMIT", "TIMEOUT", "BUSY", "ERROR")
MAX_TEXT = 4096
"""Longest text field either side accepts; what a rig sends is clipped to it (:func:`clip`)."""


def clip(text: str, limit: int = MAX_TEXT) -> str:
    """``text`` cut to ``limit`` characters (an ellipsis says so), so a peer can always
    decode what it is sent, however long the input it echoes.

    >>> clip("abcdef", 4), clip("abc", 4)
    ('abc…', 'abc')
    """
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _check(name: str, value: Any, tp: Any) -> Any:
    """``value`` converted to ``tp`` (int, float, str, bool, bytes, X | None, tuple[X, ...],
    or a Message), or InvalidFieldError."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = typing.get_args(tp)
        if value is None and type(None) in args:
            return None
        (inner,) = [a for a in args if a is not type(None)]
        return _check(name, value, inner)
    if origin is tuple:
        inner = typing.get_args(tp)[0]
        if not isinstance(value, list | tuple):
            raise InvalidFieldError(f"{name}: expected a list")
        return tuple(_check(f"{name}[{i}]", v, inner) for i, v in enumerate(value))
    if isinstance(tp, type) and issubclass(tp, Message):
        if not isinstance(value, dict):
            raise InvalidFieldError(f"{name}: expected a map")
        return tp.from_body(value)
    if tp is bool:
        if not isinstance(value, bool):
            raise InvalidFieldError(f"{name}: expected true/false")
        return value
    if tp is int:
        if not isinstance(value, int) or isinstance(value, bool):
            raise InvalidFieldError(f"{name}: expected an integer")
        return value
    if tp is float:
        if not isinstance(value, int | float) or isinstance(value, bool):
            raise InvalidFieldError(f"{name}: expected a number")
        if not math.isfinite(value):
            raise InvalidFieldError(f"{name}: must be finite")
        return float(value)
    if tp is str:
        if not isinstance(value, str) or len(value) > MAX_TEXT:
            raise InvalidFieldError(f"{name}: expected text of at most {MAX_TEXT} characters")
        return value
    if tp is bytes:
        if not isinstance(value, bytes):
            raise InvalidFieldError(f"{name}: expected binary data")
        return value
    raise TypeError(f"unsupported field type {tp!r}")


@dataclass(frozen=True)
class Message:
    """Base of every message; ``KIND`` names it in the envelope."""

    KIND: ClassVar[str] = ""

    @classmethod
    def from_body(cls, body: dict[str, Any]) -> Self:
        hints = typing.get_type_hints(cls)
        values = {}
        for f in fields(cls):
            if f.name in body:
                values[f.name] = _check(
                    f"{cls.KIND or cls.__name__}.{f.name}", body[f.name], hints[f.name]
                )
            elif f.default is MISSING and f.default_factory is MISSING:
                raise DecodeError(f"{cls.KIND}: missing field {f.name!r}")
        try:
            return cls(**values)
        except ValueError as exc:
            raise InvalidFieldError(f"{cls.KIND}: {exc}") from None

    def to_body(self) -> dict[str, Any]:
        return asdict(self)


MAX_SETTINGS = 32
"""Most ``NAME=VALUE`` settings one survey may carry (the profile has fewer fields)."""
_SETTING_TEXT = 200


def check_setting(text: str) -> str:
    """``text`` if it has the form of a parameter setting, ``NAME=VALUE`` with a name of
    letters, digits and underscores, else ValueError; what the name and value mean is the
    rig's to judge (``daemon.vision.params.with_settings``).

    >>> check_setting("uncommon=surprisal")
    'uncommon=surprisal'
    >>> check_setting("blur")
    Traceback (most recent call last):
    ...
    ValueError: setting 'blur' is not NAME=VALUE
    """
    name, sep, value = text.partition("=")
    name = name.strip()
    if (
        not sep
        or not name
        or not value.strip()
        or len(text) > _SETTING_TEXT
        or not name.replace("_", "a").isalnum()
        or not name.isascii()
    ):
        raise ValueError(f"setting {clip(text, 60)!r} is not NAME=VALUE")
    return text


def _in(name: str, value: float, lo: float, hi: float) -> None:
    if not lo <= value <= hi:
        raise ValueError(f"{name} {value} outside {lo}..{hi}")


# -- replies and telemetry ---------------------------------------------------------------


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
    KIND: ClassVar[str] = "ptu.state"
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
    """Colour difference (ΔE) from the nearest colour earlier stations of the session
    showed (2.1); None at a session's first station."""


@dataclass(frozen=True)
class InterestResult(Message):
    KIND: ClassVar[str] = "survey.result"
    station: str
    points: tuple[InterestPoint, ...] = ()
    width: int = 0
    height: int = 0


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


# -- commands ----------------------------------------------------------------------------

R = TypeVar("R", bound=Message)


@dataclass(frozen=True)
class Request(Message, Generic[R]):
    """A command: the rig answers it on ``cyborg/<rig>/cmd/<client>/<VERB>`` with a
    ``REPLY``. Everything about a command is declared on its class, and the key space, the
    daemon's dispatch, its motion set and the clients derive from it (add a command here)."""

    VERB: ClassVar[str] = ""
    REPLY: ClassVar[type[Message]] = Ack
    MOVES: ClassVar[bool] = False
    """Needs control: it moves the head (or decides where it goes)."""


@dataclass(frozen=True)
class PtuGoto(Request[Ack]):
    """Point at absolute (pan, tilt) degrees; the unit's own limits are checked later."""

    KIND: ClassVar[str] = "ptu.goto"
    VERB: ClassVar[str] = "ptu/goto"
    MOVES: ClassVar[bool] = True
    pan: float
    tilt: float

    def __post_init__(self) -> None:
        _in("pan", self.pan, -360.0, 360.0)
        _in("tilt", self.tilt, -180.0, 180.0)


@dataclass(frozen=True)
class PtuJog(Request[Ack]):
    """Step by (pan, tilt) degrees from where the head is."""

    KIND: ClassVar[str] = "ptu.jog"
    VERB: ClassVar[str] = "ptu/jog"
    MOVES: ClassVar[bool] = True
    pan: float = 0.0
    tilt: float = 0.0

    def __post_init__(self) -> None:
        _in("pan", self.pan, -90.0, 90.0)
        _in("tilt", self.tilt, -90.0, 90.0)


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
        _in("u", self.u, 0.0, 1.0)
        _in("v", self.v, 0.0, 1.0)
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

    def __post_init__(self) -> None:
        if self.rows is not None:
            _in("rows", self.rows, 1, 16)
        if self.cols is not None:
            _in("cols", self.cols, 1, 32)
        if self.downsample is not None:
            _in("downsample", self.downsample, 1.0, 16.0)
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
        _in("rank", self.rank, 0, 3)


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
    REPLY: ClassVar[type[Message]] = ArchiveListing
    session: str = ""


@dataclass(frozen=True)
class ArchiveGet(Request[ArchiveData]):
    KIND: ClassVar[str] = "archive.get"
    VERB: ClassVar[str] = "archive/get"
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
    REPLY: ClassVar[type[Message]] = FrameStream
    fps: float = 2.0
    width: int = 640
    quality: int = 70

    def __post_init__(self) -> None:
        _in("fps", self.fps, 0.1, 30.0)
        _in("width", self.width, 64, 4096)
        _in("quality", self.quality, 10, 95)

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
    major: int
    minor: int
    build: str = ""
    rig: str = ""


Hello.REPLY = Hello

REQUESTS: dict[str, type[Request]] = {r.VERB: r for r in Request.__subclasses__()}
"""Every command by verb."""


MESSAGES: dict[str, type[Message]] = {
    m.KIND: m
    for m in (
        PtuGoto,
        PtuJog,
        PtuLook,
        PtuHalt,
        PtuHome,
        SurveyStart,
        SurveyCancel,
        SurveyStatus,
        ChooseTarget,
        TakeControl,
        ReleaseControl,
        ArchiveList,
        ArchiveGet,
        Ack,
        Hello,
        PtuState,
        SurveyProgress,
        InterestPoint,
        InterestResult,
        Event,
        FrameHeader,
        FrameStream,
        StreamRequest,
        Chip,
        Status,
        ArchiveListing,
        ArchiveData,
    )
}


def message_from(kind: str, body: dict[str, Any]) -> Message | None:
    """The message of a known kind; ``None`` for kinds this side does not know (ignored)."""
    cls = MESSAGES.get(kind)
    return None if cls is None else cls.from_body(body)
