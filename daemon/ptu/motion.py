"""The PTU-46 trapezoid speed profile: move-time prediction and exact integration.

The unit jumps from rest to its base speed ``B``, ramps at ``a`` up to the desired speed
``v`` and ramps back down to ``B`` before stopping (a symmetric trapezoid, or a triangle
on short moves). With ``v <= B`` it moves at ``v`` throughout. The driver uses
:func:`move_time` for its timeouts; the emulator advances :class:`Axis` with the same
formulas, so a query mid-move shows the intermediate position the real unit would report.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Axis", "move_time"]

_EPS = 1e-9


def move_time(distance: float, speed: float, base: float, accel: float) -> float:
    """Seconds a move of ``distance`` positions takes from rest to rest.

    >>> round(move_time(6180, 1000, 1000, 2000), 2)   # D46-17 defaults, full pan sweep
    6.18
    >>> round(move_time(6180, 2900, 1000, 2000), 2)
    2.75
    """
    d = abs(distance)
    if d == 0:
        return 0.0
    if speed <= 0:
        raise ValueError("speed must be > 0")
    if speed <= base:
        return d / speed
    ramp = (speed * speed - base * base) / (2 * accel)
    if 2 * ramp >= d:
        peak = math.sqrt(base * base + accel * d)
        return 2 * (peak - base) / accel
    return 2 * (speed - base) / accel + (d - 2 * ramp) / speed


@dataclass
class Axis:
    """One axis in motion: position and signed velocity, advanced exactly by phases."""

    position: float = 0.0
    velocity: float = 0.0
    target: float = 0.0
    speed: float = 1000.0
    base: float = 1000.0
    accel: float = 2000.0

    @property
    def moving(self) -> bool:
        return self.velocity != 0.0 or abs(self.target - self.position) > _EPS

    def halt(self) -> None:
        """Decelerate to a stop: the new target is where a full ramp-down ends."""
        u = abs(self.velocity)
        base = min(self.base, self.speed)
        stop = max(u * u - base * base, 0.0) / (2 * self.accel)
        self.target = self.position + math.copysign(stop, self.velocity) if u else self.position

    def advance(self, dt: float) -> None:
        """Integrate ``dt`` seconds; each loop pass runs one phase to its end or to ``dt``."""
        a = self.accel
        for _ in range(64):
            if dt <= _EPS:
                return
            rem = self.target - self.position
            u = abs(self.velocity)
            base = min(self.base, self.speed)
            if abs(rem) <= _EPS and u <= base + _EPS:
                self.position, self.velocity = self.target, 0.0
                return
            s = math.copysign(1.0, rem) if abs(rem) > _EPS else math.copysign(1.0, self.velocity)
            if self.velocity * s < 0:  # heading away (target changed): slow to base, then reverse
                t = min((u - base) / a, dt) if u > base else 0.0
                self._ramp(-a, t)
                dt -= t
                if abs(self.velocity) <= base + _EPS:
                    self.velocity = 0.0
                continue
            u = max(u, base)
            d = abs(rem)
            stop = (u * u - base * base) / (2 * a)
            if d <= stop + _EPS:  # final ramp down; arrival may overshoot if the target moved in
                t = (u - math.sqrt(max(u * u - 2 * a * d, 0.0))) / a if u > base else d / u
                t = min(t, dt)
                self.velocity = s * u
                self._ramp(-a if u > base else 0.0, t)
                dt -= t
                if abs(self.target - self.position) <= 1e-6:
                    self.position = self.target
                    if abs(self.velocity) <= base + 1e-6:
                        self.velocity = 0.0
                continue
            if u < self.speed - _EPS:  # speed up until v or until the ramp-down must start
                t_v = (self.speed - u) / a
                t_d = (-u + math.sqrt(u * u + a * (d - stop))) / a
                t = min(t_v, t_d, dt)
                self.velocity = s * u
                self._ramp(a, t)
            elif u > self.speed + _EPS:  # desired speed lowered mid-move
                t = min((u - self.speed) / a, dt)
                self.velocity = s * u
                self._ramp(-a, t)
            else:
                t = min((d - stop) / u, dt)
                self.velocity = s * u
                self._ramp(0.0, t)
            dt -= t

    def _ramp(self, accel: float, t: float) -> None:
        """Constant acceleration along the direction of travel for ``t`` seconds."""
        s = math.copysign(1.0, self.velocity) if self.velocity else 1.0
        u = abs(self.velocity)
        self.position += s * (u * t + 0.5 * accel * t * t)
        self.velocity = s * max(u + accel * t, 0.0)
