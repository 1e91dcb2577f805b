"""The rig's hardware as the daemon shares it: one PTU, one camera, who may move them.

The PTU's last known pose is cached here from every reply that carries one (the state
poller, motion waits), so a simulated camera renders where the head is without another
round trip on a 9600-baud line, and clients get state without polling the unit.
"""

from __future__ import annotations

import asyncio
import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass

from .camera import Camera, Frame
from .camera.base import PoseSource
from .ptu import PanTiltUnit, PtuPosition

__all__ = ["Control", "Rig"]


@dataclass
class Control:
    """One client at a time holds control of motion; taking it over is explicit."""

    holder: str = ""

    def allows(self, client: str) -> bool:
        return bool(client) and client == self.holder

    def take(self, client: str) -> str:
        """Give control to ``client``; returns the previous holder ('' if none)."""
        previous, self.holder = self.holder, client
        return previous if previous != client else ""

    def release(self, client: str) -> bool:
        if client != self.holder:
            return False
        self.holder = ""
        return True


class Rig:
    def __init__(self, ptu: PanTiltUnit, camera: Callable[[PoseSource], Camera] | Camera) -> None:
        """``camera`` may be a factory taking the pose source (simulated cameras need it):
        an emulated head with errors says where it truly looks, otherwise the reported pose."""
        self.ptu = ptu
        self._truth: PoseSource | None = None
        if isinstance(camera, Camera):
            self.camera = camera
        else:
            self._truth = getattr(ptu, "true_pose", None)
            self.camera = camera(self._truth or self.pose_angles)
        self.control = Control()
        self._grab_lock = asyncio.Lock()
        self._pose = PtuPosition(0.0, 0.0, 0, 0, False, 0.0)
        self.changed = asyncio.Event()

    @property
    def pose(self) -> PtuPosition:
        return self._pose

    def note(self, position: PtuPosition) -> None:
        """Record a reported pose unless a newer one is already known."""
        if position.timestamp >= self._pose.timestamp:
            moved = (position.pan_pos, position.tilt_pos, position.moving) != (
                self._pose.pan_pos,
                self._pose.tilt_pos,
                self._pose.moving,
            )
            self._pose = position
            if moved:
                self.changed.set()

    def mark_moving(self) -> None:
        p = self._pose
        self.note(PtuPosition(p.pan, p.tilt, p.pan_pos, p.tilt_pos, True, time.time()))

    async def pose_angles(self) -> tuple[float, float]:
        """The pose source of simulated cameras."""
        return self._pose.pan, self._pose.tilt

    async def grab(self) -> Frame:
        """The camera's next frame. One rendered from where an emulated head truly looks is
        labelled with the pose the head reported, as a real rig knows only that."""
        async with self._grab_lock:
            reported = self._pose
            frame = await self.camera.grab()
        if self._truth is None or frame.pose is None:
            return frame
        return dataclasses.replace(frame, pose=(reported.pan, reported.tilt))

    def landing(self, pan: float, tilt: float) -> tuple[float, float]:
        """The pose the head will report once a move to (pan, tilt) ends: the nearest step
        (what can be prepared for that pose can be, before it stands there)."""
        info = self.ptu.info
        return (
            info.pan.to_degrees(info.pan.to_positions(pan)),
            info.tilt.to_degrees(info.tilt.to_positions(tilt)),
        )

    async def move_to(self, pan: float, tilt: float) -> PtuPosition:
        """Move and wait until the head stands still; the pose cache follows."""
        await self.ptu.move_to(pan, tilt, wait=False)
        self.mark_moving()
        return await self.settle()

    async def settle(self) -> PtuPosition:
        position = await self.ptu.wait_motion()
        self.note(position)
        return position
