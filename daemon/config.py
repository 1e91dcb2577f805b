"""``cyborgd.toml`` -> a typed, validated :class:`Config`; CLI flags override the file.

Every section and key is known: a typo is an error naming the key, not a silently
ignored setting on a rig in the field.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from cyborg.protocol.access import access_control, load_users
from cyborg.protocol.aims import parse_aim
from cyborg.protocol.keys import Keys
from cyborg.protocol.transport import Transport

from .survey.analysis import check_profile
from .survey.site import SiteConfig
from .vision.params import PROFILES

__all__ = [
    "CameraConfig",
    "Config",
    "ConfigError",
    "FramesConfig",
    "RecordConfig",
    "SurveyConfig",
    "load",
    "validate",
]


class ConfigError(ValueError):
    """A config file or override that cannot run; the text says which key and why."""


@dataclass(frozen=True)
class CameraConfig:
    url: str = "v4l2://0"
    hfov: float = 30.0
    """Horizontal field of view in degrees at the widest zoom (simulated cameras know theirs)."""
    zoom: str = ""
    """The lens's zoom line, e.g. ``visca:///dev/ttyUSB1?max=30`` (daemon.camera.visca)."""


@dataclass(frozen=True)
class FramesConfig:
    rate: float = 10.0
    """Live frames per second on the bus; 0 turns the live view off."""
    jpeg_quality: int = 80


@dataclass(frozen=True)
class RecordConfig:
    enabled: bool = True
    """Record each session to ``<archive>/<session>/session.mcap`` (daemon.record)."""
    frames: float = 1.0
    """Live frames per second in the session log, watched or not; 0: none."""


@dataclass(frozen=True)
class SurveyConfig:
    rows: int = 2
    cols: int = 3
    downsample: float = 4.0
    overlap: float = 0.0
    """Share (0..0.5) of a field of view neighbouring tiles overlap: above 0 the mosaic is
    registered and projected (``survey.stitch``), 0 butts the frames as the seed did; the
    ``paper`` profile always butts them."""
    profile: str = "default"
    settings: tuple[str, ...] = ()
    """``NAME=VALUE`` changes to whichever vision profile a survey uses, as ``cyborgd analyze
    --set`` makes them (``params.with_settings``): a choice tried offline, taken to the field."""
    aim: str = "any"
    """The aim of study (``protocol.aims``, e.g. ``dark+no-vegetation``) of a session's first
    station when the survey start names none; later stations keep the last one asked for."""
    approach: tuple[float, ...] = (300.0, 60.0, 10.0)
    """Distances (m) of the approach loop's stations: the seed walked 300 -> 60 -> 10 m."""
    simulate_approach: bool = False
    """Magnify a simulated camera by the distance ratio at each new station (no walking)."""
    settle: float = 0.0
    """Seconds to wait after motion stops before a grab (tripod vibration)."""
    speed: float | None = None
    """PTU slew speed (deg/s) during surveys; None keeps the unit's own setting."""
    zoom_on_target: bool = False
    """Intelligent zoom: on a choice, zoom on the target by the next leg's distance ratio
    instead of walking there (needs a camera with a zoom)."""
    memory: float = 0.8
    """Memory across stations: weight (0..1) of the prior a station's interest gets from the
    station it was aimed from (what was judged common from afar, the chosen target's
    surroundings; daemon.memory.station_prior); 0 turns it off. At 0.5 what was judged common
    kept half its interest, and a bed cut by the 60 m frame's edge (rare in that frame) beat
    the stain in 3 of 90 bench approaches (77 reached the core, against 82 at 0.8), measured
    before the vision discounted patches hugging the frame, which now takes such a bed down
    in one look (without memory 77 of 90, with it 81)."""
    pan0: float = 0.0
    """Centre of a survey nobody aimed (degrees), as the tripod was set up to face."""
    tilt0: float = 0.0


@dataclass(frozen=True)
class Config:
    rig: str = "rig1"
    archive: Path = Path("archive")
    ptu: str = "serial:///dev/ptu"
    camera: CameraConfig = field(default_factory=CameraConfig)
    zenoh: Transport = field(default_factory=lambda: Transport(listen=("tcp/127.0.0.1:7447",)))
    frames: FramesConfig = field(default_factory=FramesConfig)
    survey: SurveyConfig = field(default_factory=SurveyConfig)
    record: RecordConfig = field(default_factory=RecordConfig)
    site: SiteConfig = field(default_factory=SiteConfig)
    state_rate: float = 10.0
    """PTU state messages per second (plus one on every change of motion)."""

    @property
    def keys(self) -> Keys:
        return Keys(self.rig)


def _typed(section: str, cls: type, table: Any) -> Any:
    if not isinstance(table, dict):
        raise ConfigError(f"[{section}] must be a table")
    known = {f.name: f for f in fields(cls)}
    unknown = sorted(set(table) - set(known))
    if unknown:
        raise ConfigError(f"unknown key(s) in [{section}]: {', '.join(unknown)}")
    values: dict[str, Any] = {}
    for name, value in table.items():
        values[name] = _coerce(f"{section}.{name}", value, getattr(cls(), name))
    try:
        return cls(**values)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"[{section}]: {exc}") from None


def _coerce(name: str, value: Any, default: Any) -> Any:
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ConfigError(f"{name}: expected true or false")
        return value
    if isinstance(default, float) or default is None:  # None: an optional number
        if not isinstance(value, int | float) or isinstance(value, bool):
            raise ConfigError(f"{name}: expected a number")
        return float(value)
    if isinstance(default, int):
        if not isinstance(value, int) or isinstance(value, bool):
            raise ConfigError(f"{name}: expected an integer")
        return value
    if isinstance(default, tuple):
        if not isinstance(value, list):
            raise ConfigError(f"{name}: expected a list")
        return tuple(value)
    if isinstance(default, str) and not isinstance(value, str):
        raise ConfigError(f"{name}: expected text")
    return value


def _in(value: float | None, lo: float, hi: float) -> bool:
    return value is None or lo <= value <= hi


def validate(cfg: Config) -> Config:
    """Check a whole configuration (after any CLI overrides); ConfigError says what."""
    try:
        cfg.keys  # noqa: B018 - validates the rig name
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    s = cfg.survey
    checks = [
        (0 < cfg.camera.hfov < 180, "camera.hfov must be in (0, 180) degrees"),
        (0 <= cfg.frames.rate <= 60, "frames.rate must be 0..60 per second"),
        (0 <= cfg.record.frames <= 30, "record.frames must be 0..30 per second"),
        (_in(cfg.site.latitude, -90, 90), "site.latitude must be -90..90 degrees"),
        (_in(cfg.site.longitude, -180, 180), "site.longitude must be -180..180 degrees"),
        (_in(cfg.site.heading, 0, 360), "site.heading must be 0..360 degrees from north"),
        (-45 <= cfg.site.level <= 45, "site.level must be -45..45 degrees"),
        (1 <= cfg.frames.jpeg_quality <= 100, "frames.jpeg_quality must be 1..100"),
        (1 <= s.rows <= 16 and 1 <= s.cols <= 32, "survey.rows 1..16 and survey.cols 1..32"),
        (1 <= s.downsample <= 16, "survey.downsample must be 1..16"),
        (0 <= s.overlap <= 0.5, "survey.overlap must be 0..0.5"),
        (s.profile in PROFILES, f"survey.profile must be one of {', '.join(sorted(PROFILES))}"),
        (
            len(s.approach) >= 1 and all(isinstance(d, int | float) and d > 0 for d in s.approach),
            "survey.approach must list positive distances",
        ),
        (s.settle >= 0, "survey.settle must be >= 0"),
        (0 <= s.memory <= 1, "survey.memory must be in [0, 1]"),
        (s.speed is None or s.speed > 0, "survey.speed must be > 0"),
        (0 < cfg.state_rate <= 50, "state_rate must be in (0, 50]"),
    ]
    for ok, text in checks:
        if not ok:
            raise ConfigError(text)
    if not all(isinstance(item, str) for item in s.settings):
        raise ConfigError('survey.settings must list "NAME=VALUE" texts')
    try:  # a survey may ask for any profile: each must take the settings
        for name in PROFILES:
            check_profile(name, s.settings)
    except ValueError as exc:
        raise ConfigError(f"survey.{exc}") from None
    try:
        aim = parse_aim(s.aim).text
    except ValueError as exc:
        raise ConfigError(f"survey.aim: {exc}") from None
    # [zenoh] checked itself (protocol.transport): clear text, anonymous TLS
    return replace(cfg, survey=replace(s, aim=aim))


def load(path: Path | None = None, **overrides: Any) -> Config:
    """Read ``path`` (if any), apply non-None ``overrides`` (top-level fields), validate.

    >>> load(rig="bench", ptu="emu://").ptu
    'emu://'
    """
    data: dict[str, Any] = {}
    if path is not None:
        try:
            data = tomllib.loads(Path(path).read_text())
        except OSError as exc:
            raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None
        except tomllib.TOMLDecodeError as exc:
            raise ConfigError(f"{path}: not valid TOML: {exc}") from None
    sections = {
        "camera": CameraConfig,
        "frames": FramesConfig,
        "survey": SurveyConfig,
        "record": RecordConfig,
        "site": SiteConfig,
    }
    top = {f.name for f in fields(Config)}
    unknown = sorted(set(data) - top)
    if unknown:
        raise ConfigError(f"unknown key(s) in {path}: {', '.join(unknown)}")
    values: dict[str, Any] = {}
    for name, value in data.items():
        if name in sections:
            values[name] = _typed(name, sections[name], value)
        elif name == "zenoh":
            rig = overrides.get("rig") or data.get("rig", Config.rig)
            base = Path(path).parent if path is not None else Path()
            values[name] = _transport(value, rig if isinstance(rig, str) else Config.rig, base)
        elif name == "archive":
            values[name] = Path(_coerce(name, value, ""))
        else:
            values[name] = _coerce(name, value, getattr(Config(), name))
    cfg = Config(**values)
    cfg = replace(cfg, **{k: v for k, v in overrides.items() if v is not None})
    return validate(cfg)


_FILES = ("tls_ca", "tls_cert", "tls_key", "users", "passwords")
"""[zenoh] keys naming files; relative paths are relative to the config file's folder."""


def _transport(table: Any, rig: str, base: Path) -> Transport:
    """[zenoh]: Transport's fields, plus ``users``, a users file (protocol.access) from
    which the access-control list is generated."""
    if not isinstance(table, dict):
        raise ConfigError("[zenoh] must be a table")
    known = ({f.name for f in fields(Transport)} - {"access"}) | {"users"}
    unknown = sorted(set(table) - known)
    if unknown:
        raise ConfigError(f"unknown key(s) in [zenoh]: {', '.join(unknown)}")
    values = dict(table)
    for name in ("listen", "connect"):
        if name in values:
            eps = values[name]
            if not isinstance(eps, list) or not all(isinstance(e, str) for e in eps):
                raise ConfigError(f"zenoh.{name}: expected a list of endpoints")
            values[name] = tuple(eps)
    for name in _FILES:
        if name in values:
            if not isinstance(values[name], str):
                raise ConfigError(f"zenoh.{name}: expected a file name")
            values[name] = str(base / values[name]) if values[name] else ""
    users = values.pop("users", "")
    try:
        if users:
            text = Path(users).read_text()
            values["access"] = access_control(Keys(rig), load_users(text, rig))
        return Transport(**values)
    except OSError as exc:
        raise ConfigError(f"zenoh.users: {users}: {exc.strerror or exc}") from None
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"[zenoh]: {exc}") from None
