"""A PTU-46 controller emulator, sans I/O: bytes in, bytes out, motion on a scaled clock.

It follows ``shared/reference/ptu46.md``: echo on and verbose feedback at power-up,
``ED/EE/FT/FV``, D46 error wording, soft limits with ``LE/LD`` (and mechanical stops
beyond them that report ``!P``/``!T``), immediate and slaved execution, ``A`` answering
only when motion ends, ``R`` calibration, the trapezoid profile integrated exactly so a
query mid-move shows where the head is, and power-up defaults with ``DS/DR/DF``.
With :class:`~.emulator_errors.HeadErrors` it also plays a real head's pointing error and
backlash: it reports its step count while :meth:`Ptu46Emulator.pointing` says where the head
truly looks (what a simulated camera renders from).

The command table is :mod:`.emulator_commands`. Transport lives elsewhere:
:mod:`daemon.ptu.ptyserver` puts this on a pseudo-terminal,
:class:`daemon.ptu.emulated.EmulatedPtu` calls it in-process.
"""

from __future__ import annotations

import math
import re
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

from .emulator_commands import HANDLERS
from .emulator_errors import HeadErrors
from .models import MODELS, PtuModel
from .motion import Axis, move_time

__all__ = ["Ptu46Emulator"]

_TOKEN = re.compile(r"([A-Z_@]+)([-+]?\d+)?\Z")
_DELIMITERS = b" \r\n"
_SETTINGS = ("echo", "verbose", "limits", "immediate", "velocity_mode")
_AXIS_SETTINGS = ("speed", "base", "accel", "upper", "lower")


@dataclass
class _AxisState:
    """One axis: its kinematics plus the settings the unit keeps for it."""

    name: str
    """``Pan`` or ``Tilt``, as the verbose replies spell it."""
    letter: str
    lo: int
    hi: int
    resolution: float
    motion: Axis
    upper: int
    lower: int
    stop_margin: int
    pending: int | None = None
    """Slaved-mode target waiting for ``A``."""
    hold_power: str = "REGULAR"
    move_power: str = "REGULAR"
    stalled: bool = False
    """Ran into a mechanical stop; the step count is no longer trusted until ``R``."""
    shaft: float = 0.0
    """Where the output shaft is, positions: the motor's position, give or take backlash."""

    @property
    def position(self) -> int:
        return round(self.motion.position)


@dataclass
class _Deferred:
    """A reply that waits for motion to end (``A``) or calibration to finish (``R``)."""

    text: str
    due: float | None = None
    """Emulated time at which to answer; ``None``: when both axes stop."""
    then: Callable[[], None] | None = None


@dataclass
class Ptu46Emulator:
    """The controller: feed it received bytes, collect what it writes back."""

    model: PtuModel = field(default_factory=lambda: MODELS["D46-17"])
    time_scale: float = 1.0
    """Emulated seconds per real second (> 1 runs faster than real time)."""
    clock: Callable[[], float] = time.monotonic
    errors: HeadErrors = field(default_factory=HeadErrors)
    """A real head's pointing error and backlash (none by default)."""

    def __post_init__(self) -> None:
        if self.time_scale <= 0:
            raise ValueError("time_scale must be > 0")
        m = self.model
        self._t0 = self.clock()
        self._last = 0.0
        self.pan = self._axis("Pan", "P", m.pan_min, m.pan_max, m.pan_resolution)
        self.tilt = self._axis("Tilt", "T", m.tilt_min, m.tilt_max, m.tilt_resolution)
        # Power-up defaults: echo on, verbose, soft limits, immediate, position control.
        self.echo = self.verbose = self.limits = self.immediate = True
        self.velocity_mode = False
        self._factory = self._snapshot()
        self._saved = self._factory
        self._token = bytearray()
        self._queue = bytearray()
        self._deferred: _Deferred | None = None
        self._unit_id = 0
        self._selected = True
        self.commands_seen = 0
        self.executed: Counter[str] = Counter()
        """How often each known command (its letters: ``PP``, ``TP``, ``H``) was run, set
        or query alike: which the driver sends, for tests to read."""

    def _axis(self, name: str, letter: str, lo: int, hi: int, res: float) -> _AxisState:
        m = self.model
        motion = Axis(speed=m.speed, base=m.base_speed, accel=m.accel)
        return _AxisState(
            name, letter, lo, hi, res, motion, m.upper_speed, m.lower_speed, m.hard_stop_margin
        )

    # -- clock ---------------------------------------------------------------------------

    def now(self) -> float:
        """Emulated seconds since power-up."""
        return (self.clock() - self._t0) * self.time_scale

    def _advance(self) -> bytes:
        """Bring both axes to ``now``; report any axis that ran into its mechanical stop."""
        t = self.now()
        dt, self._last = t - self._last, t
        out = b""
        for ax in (self.tilt, self.pan):
            ax.motion.advance(dt)
            lo, hi = ax.lo - ax.stop_margin, ax.hi + ax.stop_margin
            if not lo <= ax.motion.position <= hi:
                ax.motion.position = min(max(ax.motion.position, lo), hi)
                ax.motion.target, ax.motion.velocity = ax.motion.position, 0.0
                ax.stalled = True
                out += b"!" + ax.letter.encode() + b"\r\n"
            half = self._band(ax) / 2.0
            ax.shaft = min(max(ax.shaft, ax.motion.position - half), ax.motion.position + half)
        return out

    def _band(self, ax: _AxisState) -> float:
        """The axis's backlash, positions."""
        return self.errors.backlash[ax is self.tilt] * 3600.0 / ax.resolution

    def pointing(self) -> tuple[float, float]:
        """Where the head truly looks, (pan, tilt) degrees, as of the last time the emulator
        ran: the output shafts plus the pointing error (the reported count when there are no
        errors and the head is still)."""
        pan, tilt = (ax.shaft * ax.resolution / 3600.0 for ax in (self.pan, self.tilt))
        dp, dt = self.errors.offset(pan, tilt)
        return pan + dp, tilt + dt

    # -- I/O -----------------------------------------------------------------------------

    def receive(self, data: bytes) -> bytes:
        """Take bytes from the host; return what the unit writes back right away."""
        self._queue += data
        return self._advance() + self._drain()

    def poll(self) -> bytes:
        """Output that became due since the last call (``A``/``R`` replies, limit events)."""
        out = self._advance()
        d = self._deferred
        if d is not None and (
            (d.due is None and not (self.pan.motion.moving or self.tilt.motion.moving))
            or (d.due is not None and self.now() >= d.due)
        ):
            self._deferred = None
            if d.then:
                d.then()
            out += self._line(d.text)
            out += self._drain()
        return out

    @property
    def busy(self) -> bool:
        """A blocking command (``A``, ``R``) is running; input waits in the queue."""
        return self._deferred is not None

    @property
    def moving(self) -> bool:
        self._advance()
        return self.pan.motion.moving or self.tilt.motion.moving

    def _drain(self) -> bytes:
        out = bytearray()
        while self._queue and self._deferred is None:
            byte = self._queue[:1]
            del self._queue[:1]
            if self.echo and self._selected:
                out += byte
            if byte in (b" ", b"\r", b"\n"):
                if self._token:
                    token = self._token.decode("ascii", "replace").upper()
                    self._token.clear()
                    out += self._execute(token)
            elif len(self._token) < 64:
                self._token += byte
        return bytes(out)

    def _line(self, text: str) -> bytes:
        return (text + "\r\n").encode("ascii") if self._selected else b""

    def _execute(self, token: str) -> bytes:
        self.commands_seen += 1
        if token == "?":
            return self._line("* " + ", ".join(sorted({k[:2] for k in HANDLERS})))
        m = _TOKEN.match(token)
        handler = HANDLERS.get(m.group(1)) if m else None
        if m is None or handler is None:
            return self._line("! " + self.model.illegal_message)
        self.executed[m.group(1)] += 1
        result = handler(self, _int(m.group(2)))
        if result is None:  # deferred until motion ends, or nothing to say
            return b""
        return self._line(result)

    # -- state helpers -------------------------------------------------------------------

    def _snapshot(self) -> dict[str, object]:
        snap: dict[str, object] = {}
        for ax in (self.pan, self.tilt):
            snap.update({f"{ax.letter}{k}": getattr(ax, k) for k in ("upper", "lower")})
            snap.update(
                {f"{ax.letter}{k}": getattr(ax.motion, k) for k in ("speed", "base", "accel")}
            )
        snap.update({k: getattr(self, k) for k in _SETTINGS})
        return snap

    def _restore(self, snap: dict[str, object]) -> None:
        for ax in (self.pan, self.tilt):
            for k in ("upper", "lower"):
                setattr(ax, k, snap[f"{ax.letter}{k}"])
            for k in ("speed", "base", "accel"):
                setattr(ax.motion, k, snap[f"{ax.letter}{k}"])
        for k in _SETTINGS:
            setattr(self, k, snap[k])

    def power_cycle(self) -> None:
        """Power off and on: saved defaults come back, the head calibrates to (0, 0)."""
        self._restore(self._saved)
        for ax in (self.pan, self.tilt):
            ax.motion.position = ax.motion.target = ax.motion.velocity = ax.shaft = 0.0
            ax.pending, ax.stalled = None, False
        self._token.clear()
        self._queue.clear()
        self._deferred = None
        self._selected = True

    def _text(self, verbose: str, terse: object) -> str:
        return "* " + (verbose if self.verbose else str(terse))

    def _set_target(self, ax: _AxisState, pos: int) -> str:
        if self.limits and pos > ax.hi:
            return f"! Maximum allowable {ax.name} position is {ax.hi}"
        if self.limits and pos < ax.lo:
            return f"! Minimum allowable {ax.name} position is {ax.lo}"
        if self.immediate:
            ax.motion.target = float(pos)
        else:
            ax.pending = pos
        return "*"

    def _set_speed(self, ax: _AxisState, value: int) -> str:
        if abs(value) > ax.upper:
            return f"! {ax.name} speed cannot exceed {ax.upper} positions/sec"
        if self.velocity_mode:
            if value and abs(value) < ax.lower:
                return f"! Motor speed cannot be less than {ax.lower} pos/sec"
            ax.motion.speed = float(abs(value) or ax.motion.speed)
            if value == 0:
                ax.motion.halt()
            else:
                stop = ax.hi if value > 0 else ax.lo
                ax.motion.target = float(
                    stop if self.limits else stop + math.copysign(ax.stop_margin + 1, value)
                )
            return "*"
        if value < ax.lower:
            return f"! Motor speed cannot be less than {ax.lower} pos/sec"
        ax.motion.speed = float(value)
        return "*"

    def _calibrate(self) -> str | None:
        """``R``: each axis runs to both stops and back to centre; answer when done."""
        seconds = 0.0
        for ax in (self.tilt, self.pan):
            m = ax.motion
            path = (abs(ax.hi - m.position), ax.hi - ax.lo, abs(ax.lo))
            seconds += sum(move_time(d, ax.upper, m.base, m.accel) for d in path)

        def done() -> None:
            for ax in (self.pan, self.tilt):
                ax.motion.position = ax.motion.target = ax.motion.velocity = ax.shaft = 0.0
                ax.stalled = False

        for ax in (self.pan, self.tilt):
            ax.motion.velocity = 0.0
            ax.motion.target = ax.motion.position
        self._deferred = _Deferred("!T!T!P!P*", self.now() + seconds, done)
        return None

    def _await_motion(self) -> None:
        """``A``: slaved targets become the axes' targets; answer when both axes stop."""
        for ax in (self.pan, self.tilt):
            if ax.pending is not None:
                ax.motion.target, ax.pending = float(ax.pending), None
        self._deferred = _Deferred("*")


def _int(text: str | None) -> int | None:
    return None if text is None else int(text)
