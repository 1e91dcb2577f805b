"""The PanTiltUnit verbs over the PTU-46 command language, shared by every backend.

A backend only supplies :meth:`CommandedPtu._request`: send one command, return the
parsed reply. Everything else, from the connect-time queries to soft-limit checks,
motion waits and halts, is here, so the in-process emulator and the serial driver
behave alike.
"""

from __future__ import annotations

import asyncio
import logging
import math
import time
from abc import abstractmethod

from .base import AxisInfo, LinkState, PanTiltUnit, PtuInfo, PtuPosition
from .errors import (
    PtuConnectionError,
    PtuLimitError,
    PtuProtocolError,
    PtuSpeedError,
    command_error,
)
from .motion import move_time
from .wire import Reply, reply_float, reply_int

__all__ = ["CommandedPtu"]

_LOGGER = logging.getLogger(__name__)

POLL_INTERVAL = 0.005
"""Pause between position polls while waiting for motion. Each poll is a query per axis still
on its way, about 11 ms each of a 9600-baud line, so the line sets the pace; the pause only
yields to others."""
STALL_SECONDS = 0.25
"""No change for this long means the head stopped (7 positions even at the 31 pos/s floor)."""


class CommandedPtu(PanTiltUnit):
    """Shared verbs; subclasses implement :meth:`_request` and the link lifecycle."""

    def __init__(self) -> None:
        self._info: PtuInfo | None = None
        self._state = LinkState.DISCONNECTED
        self._target: list[int | None] = [None, None]
        self._last = (0, 0)
        self.limit_events: list[tuple[float, str]] = []
        """(time, axis letter) of every ``!P``/``!T`` the unit reported."""

    # -- what backends provide -----------------------------------------------------------

    @abstractmethod
    async def _request(
        self,
        command: str,
        value: int | None = None,
        *,
        numeric: bool = False,
        timeout: float | None = None,
    ) -> Reply:
        """Send one command and return its reply (``ok`` or not). ``numeric``: the reply
        must carry a number, anything else is stale and skipped."""

    # -- helpers -------------------------------------------------------------------------

    @property
    def state(self) -> LinkState:
        return self._state

    @property
    def info(self) -> PtuInfo:
        if self._info is None:
            raise PtuConnectionError("PTU not connected yet")
        return self._info

    def _limit_event(self, axis: str) -> None:
        self.limit_events.append((time.time(), axis))
        _LOGGER.warning("PTU %s axis reports a limit (!%s)", "pan" if axis == "P" else "tilt", axis)

    async def _do(self, command: str, value: int | None = None, **kw: object) -> Reply:
        reply = await self._request(command, value, **kw)  # type: ignore[arg-type]
        if not reply.ok:
            raise command_error(f"{command}{'' if value is None else value}", reply.text)
        return reply

    async def _resync(self) -> bool:
        """Bring the link back in step after a doubtful reply; False if the unit answers
        nothing. In-process there is no line to fall out of step."""
        return True

    async def _int(self, command: str) -> int:
        reply = await self._do(command, numeric=True)
        value = reply_int(reply)
        if value is None:
            raise PtuProtocolError(f"{command}: no number in reply {reply.text!r}")
        return value

    async def _initialise(self) -> None:
        """Echo off, terse, immediate, position control; then ask the unit about itself."""
        for cmd in ("ED", "FT", "I", "CI"):
            await self._do(cmd)
        axes = []
        for a in "PT":
            res_reply = await self._do(f"{a}R", numeric=True)
            res = reply_float(res_reply)
            if not res or res <= 0:
                raise PtuProtocolError(f"{a}R: bad resolution {res_reply.text!r}")
            q = {k: await self._int(f"{a}{k}") for k in "NXBULAS"}
            axes.append(AxisInfo(res, q["N"], q["X"], q["B"], q["U"], q["L"], q["A"], q["S"]))
        limits = await self._do("L")
        version = (await self._do("V")).text
        self._info = PtuInfo(axes[0], axes[1], "DISABLED" not in limits.text.upper(), version)
        pos = (await self._axis_position(0), await self._axis_position(1))
        self._last = pos
        self._target = [pos[0], pos[1]]
        _LOGGER.info(
            "PTU ready: %s; pan %.2f..%.2f deg, tilt %.2f..%.2f deg, %.4f deg/position",
            version,
            axes[0].min_deg,
            axes[0].max_deg,
            axes[1].min_deg,
            axes[1].max_deg,
            axes[0].degrees_per_position,
        )

    def _axis(self, index: int) -> AxisInfo:
        return self.info.pan if index == 0 else self.info.tilt

    def _reachable(self, index: int) -> tuple[int, int]:
        """Positions the head can report: the limits the unit gave at connect, or with them
        disabled, up to the mechanical stops an eighth of the span beyond (the unit does
        not report those)."""
        ax = self._axis(index)
        slack = 0 if self.info.limits_enabled else (ax.max_pos - ax.min_pos) // 8
        return ax.min_pos - slack, ax.max_pos + slack

    async def _axis_position(self, index: int) -> int:
        """One axis's position. A value the head cannot be at is a corrupted or stray line,
        never a position: the link is resynchronised and asked once more, then it is a
        ``PtuProtocolError``, so an impossible pose is never published or archived."""
        command = f"{'PT'[index]}P"
        lo, hi = self._reachable(index)
        for attempt in (1, 2):
            value = await self._int(command)
            if lo <= value <= hi:
                return value
            _LOGGER.warning(
                "PTU answered %s with %d, outside %d..%d: %s",
                command,
                value,
                lo,
                hi,
                "resynchronising and asking again" if attempt == 1 else "refused",
            )
            await self._resync()
        raise PtuProtocolError(f"{command}: the unit twice reported a position outside {lo}..{hi}")

    def _positions(self, pan: float | None, tilt: float | None) -> list[int | None]:
        out: list[int | None] = []
        for i, deg in enumerate((pan, tilt)):
            if deg is None:
                out.append(None)
                continue
            if not math.isfinite(deg):
                raise ValueError(f"angle must be finite, got {deg!r}")
            ax = self._axis(i)
            pos = ax.to_positions(deg)
            if self.info.limits_enabled and not ax.min_pos <= pos <= ax.max_pos:
                name = "pan" if i == 0 else "tilt"
                raise PtuLimitError(
                    f"{'PT'[i]}P{pos}",
                    f"{name} {deg:.3f} deg is outside the soft limits "
                    f"{ax.min_deg:.3f}..{ax.max_deg:.3f} deg",
                )
            out.append(pos)
        return out

    def _as_position(self, pan: int, tilt: int, moving: bool) -> PtuPosition:
        return PtuPosition(
            self.info.pan.to_degrees(pan), self.info.tilt.to_degrees(tilt), pan, tilt, moving
        )

    # -- verbs ---------------------------------------------------------------------------

    async def position(self) -> PtuPosition:
        return await self._poll((0, 1))

    async def _poll(self, axes: tuple[int, ...]) -> PtuPosition:
        """Query ``axes``; the others keep the positions last read."""
        now = list(self._last)
        for i in axes:
            now[i] = await self._axis_position(i)
        pan, tilt = now
        moving = (pan, tilt) != self._last or any(
            t is not None and t != p for t, p in zip(self._target, (pan, tilt), strict=True)
        )
        self._last = (pan, tilt)
        self.last_position = self._as_position(pan, tilt, moving)
        return self.last_position

    async def move_to(
        self, pan: float | None = None, tilt: float | None = None, *, wait: bool = True
    ) -> PtuPosition:
        targets = self._positions(pan, tilt)
        for i, pos in enumerate(targets):
            if pos is not None:
                await self._do(f"{'PT'[i]}P", pos)
                self._target[i] = pos
        if wait:
            return await self.wait_motion()
        return self._as_position(*self._last, moving=True)

    async def move_by(
        self, pan: float = 0.0, tilt: float = 0.0, *, wait: bool = True
    ) -> PtuPosition:
        here = await self.position()
        return await self.move_to(
            here.pan + pan if pan else None, here.tilt + tilt if tilt else None, wait=wait
        )

    def predict_move_time(self, pan: float | None = None, tilt: float | None = None) -> float:
        times = [0.0]
        for i, deg in enumerate((pan, tilt)):
            if deg is not None:
                ax = self._axis(i)
                times.append(
                    move_time(ax.to_positions(deg) - self._last[i], ax.speed, ax.base, ax.accel)
                )
        return max(times)

    async def wait_motion(self, timeout: float | None = None) -> PtuPosition:
        if timeout is None:
            goal = [t if t is not None else self._last[i] for i, t in enumerate(self._target)]
            timeout = 2.0 + 1.5 * self.predict_move_time(
                self.info.pan.to_degrees(goal[0]), self.info.tilt.to_degrees(goal[1])
            )
        loop = asyncio.get_running_loop()
        changed_at = loop.time()
        last = self._last
        axes: tuple[int, ...] = (0, 1)
        async with asyncio.timeout(timeout):
            while True:
                here = await self._poll(axes)
                now = loop.time()
                if (here.pan_pos, here.tilt_pos) != last:
                    last, changed_at = (here.pan_pos, here.tilt_pos), now
                # The trapezoid ends exactly on the target and never overshoots, so
                # reaching it means stopped; no second poll to confirm.
                if all(t is None or t == p for t, p in zip(self._target, last, strict=True)):
                    return self._as_position(*last, moving=False)
                # An axis seen on its target has stopped there: only the others are asked
                # again, so a one-axis move's stop is seen in half the line's time.
                axes = tuple(i for i in (0, 1) if self._target[i] not in (None, last[i]))
                if now - changed_at >= STALL_SECONDS:
                    # Stopped short of the target: a halt, a mechanical stop, a stall.
                    self._target = list(last)
                    return self._as_position(*last, moving=False)
                await asyncio.sleep(POLL_INTERVAL)

    async def halt(self) -> None:
        await self._do("H")
        self._target = [None, None]

    async def set_speed(self, pan: float | None = None, tilt: float | None = None) -> None:
        await self._set_rate("S", pan, tilt)

    async def set_acceleration(self, pan: float | None = None, tilt: float | None = None) -> None:
        await self._set_rate("A", pan, tilt)

    async def _set_rate(self, kind: str, pan: float | None, tilt: float | None) -> None:
        info = self.info
        axes = [info.pan, info.tilt]
        for i, deg in enumerate((pan, tilt)):
            if deg is None:
                continue
            if not math.isfinite(deg) or deg <= 0:
                raise ValueError(f"rate must be a positive number, got {deg!r}")
            ax = axes[i]
            value = ax.to_positions(deg)
            cmd = f"{'PT'[i]}{kind}"
            if kind == "S" and not ax.lower <= value <= ax.upper:
                raise PtuSpeedError(
                    f"{cmd}{value}",
                    f"{deg:.2f} deg/s is outside {ax.to_degrees(ax.lower):.2f}.."
                    f"{ax.to_degrees(ax.upper):.2f} deg/s",
                )
            await self._do(cmd, value)
            field = "speed" if kind == "S" else "accel"
            axes[i] = AxisInfo(**{**vars(ax), field: value})
        self._info = PtuInfo(axes[0], axes[1], info.limits_enabled, info.version)

    async def reset(self) -> None:
        info = self.info
        seconds = sum(
            move_time(d, ax.upper, ax.base, ax.accel)
            for ax in (info.pan, info.tilt)
            for d in (ax.max_pos - ax.min_pos, ax.max_pos, ax.min_pos)
        )
        await self._do("R", timeout=10.0 + 2.0 * seconds)
        await self._initialise()
