"""The camera interface: grab a frame, know the resolution, zoom where there is a zoom.

::

    CameraError                 root
    └── CameraUnavailableError  the device or file cannot be opened or stopped delivering
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Camera", "CameraError", "CameraUnavailableError", "Exposure", "Frame", "PoseSource"]

PoseSource = Callable[[], Awaitable[tuple[float, float]]]
"""Where the head points now, (pan, tilt) degrees: what a simulated camera renders from."""


class CameraError(Exception):
    """Root of every camera error."""


class CameraUnavailableError(CameraError):
    """Opening or reading failed, also after the backend's reconnect attempts."""


@dataclass(frozen=True)
class Exposure:
    """What is known about how a frame was exposed (``None`` where the device won't say)."""

    seconds: float | None = None
    gain_db: float | None = None
    auto: bool | None = None


@dataclass(frozen=True)
class Frame:
    image: np.ndarray
    """(M, N, 3) uint8 BGR."""
    timestamp: float
    """Wall-clock seconds when the frame was captured."""
    seq: int
    exposure: Exposure = field(default_factory=Exposure)
    pose: tuple[float, float] | None = None
    """(pan, tilt) degrees the frame was rendered at, for simulated cameras."""


class Camera(ABC):
    """One camera. ``grab`` never blocks the event loop."""

    @property
    @abstractmethod
    def resolution(self) -> tuple[int, int]:
        """(width, height) of the frames ``grab`` returns."""

    @property
    def hfov(self) -> float | None:
        """Horizontal field of view in degrees at the widest zoom, if the camera knows it
        (a real lens does not say; the config supplies it)."""
        return None

    @property
    def extent(self) -> tuple[tuple[float, float], tuple[float, float]] | None:
        """(pan, tilt) ranges, (min, max) degrees, of the directions this camera has pixels
        for (a simulated camera's panorama), which a survey's mosaic must stay within; None
        for a camera that sees wherever it points."""
        return None

    @abstractmethod
    async def open(self) -> None: ...

    @abstractmethod
    async def close(self) -> None: ...

    @abstractmethod
    async def grab(self) -> Frame: ...

    @property
    def has_zoom(self) -> bool:
        """Whether :meth:`zoom` changes anything (a zoom lens, or a simulated one)."""
        return False

    async def zoom(self, level: float) -> float:
        """Set the magnification (1 = widest); returns the seconds it took. Cameras
        without a zoom ignore it."""
        return 0.0

    async def __aenter__(self) -> Camera:
        await self.open()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()
