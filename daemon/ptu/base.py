"""The pan-tilt unit interface every backend implements, in degrees.

Backends are chosen by URL (:func:`daemon.ptu.open_ptu`): ``serial://`` drives a real unit,
``pty://`` drives the emulator through the same serial driver, ``emu://`` calls the
emulator in-process. Angles are degrees, pan positive to the right, tilt positive up.
"""

from __future__ import annotations

import enum
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field

from ..pointing.geometry import degrees_to_positions, positions_to_degrees

__all__ = ["AxisInfo", "LinkState", "PanTiltUnit", "PtuInfo", "PtuPosition"]


class LinkState(enum.Enum):
    DISCONNECTED = "disconnected"
    CONNECTING = "connecting"
    READY = "ready"
    FAULT = "fault"


@dataclass(frozen=True)
class AxisInfo:
    """What the unit reported about one axis at connect (positions and positions/s)."""

    resolution: float
    """Arc-seconds per position."""
    min_pos: int
    max_pos: int
    base: int
    upper: int
    lower: int
    accel: int
    speed: int

    @property
    def degrees_per_position(self) -> float:
        return self.resolution / 3600.0

    def to_degrees(self, positions: float) -> float:
        return positions_to_degrees(positions, self.resolution)

    def to_positions(self, degrees: float) -> int:
        return degrees_to_positions(degrees, self.resolution)

    @property
    def min_deg(self) -> float:
        return self.to_degrees(self.min_pos)

    @property
    def max_deg(self) -> float:
        return self.to_degrees(self.max_pos)


@dataclass(frozen=True)
class PtuInfo:
    pan: AxisInfo
    tilt: AxisInfo
    limits_enabled: bool
    version: str


@dataclass(frozen=True)
class PtuPosition:
    pan: float
    """Degrees."""
    tilt: float
    pan_pos: int
    """Unit positions, as the unit reported them."""
    tilt_pos: int
    moving: bool
    timestamp: float = field(default_factory=time.time)


class PanTiltUnit(ABC):
    """One pan-tilt head. Methods raise :class:`daemon.ptu.errors.PtuError` subclasses."""

    last_position: PtuPosition | None = None
    """The latest position any caller read (motion waits poll often: others may reuse it)."""

    @property
    @abstractmethod
    def state(self) -> LinkState: ...

    @property
    @abstractmethod
    def info(self) -> PtuInfo:
        """Queried from the unit at connect; raises ``PtuConnectionError`` before."""

    @abstractmethod
    async def open(self) -> None: ...

    @abstractmethod
    async def close(self) -> None:
        """Halt the head if it is moving, then release the link."""

    @abstractmethod
    async def move_to(
        self, pan: float | None = None, tilt: float | None = None, *, wait: bool = True
    ) -> PtuPosition:
        """Absolute move in degrees; ``None`` leaves an axis where it is."""

    @abstractmethod
    async def move_by(
        self, pan: float = 0.0, tilt: float = 0.0, *, wait: bool = True
    ) -> PtuPosition:
        """Relative move in degrees from the current position."""

    @abstractmethod
    async def wait_motion(self, timeout: float | None = None) -> PtuPosition:
        """Return when both axes have stopped at their targets."""

    @abstractmethod
    async def halt(self) -> None: ...

    @abstractmethod
    async def position(self) -> PtuPosition: ...

    @abstractmethod
    async def set_speed(self, pan: float | None = None, tilt: float | None = None) -> None:
        """Desired slew speed in degrees/s; checked against the unit's bounds first."""

    @abstractmethod
    async def set_acceleration(self, pan: float | None = None, tilt: float | None = None) -> None:
        """Degrees/s²; the unit refuses while the axis moves."""

    @abstractmethod
    async def reset(self) -> None:
        """Recalibrate against the end stops (seconds to tens of seconds)."""

    @abstractmethod
    def predict_move_time(self, pan: float | None = None, tilt: float | None = None) -> float:
        """Seconds the unit's speed profile needs from the last known position to (pan, tilt)."""

    async def __aenter__(self) -> PanTiltUnit:
        await self.open()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()
