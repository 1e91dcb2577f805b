"""PTU model profiles: the numbers a unit reports about itself, as data.

The driver never uses these: it queries the unit. The emulator answers from them.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["MODELS", "PtuModel"]


@dataclass(frozen=True)
class PtuModel:
    """What one controller/head combination reports and how it moves (positions, seconds)."""

    name: str
    verified: bool
    """False where the values are inferred rather than read from a manual."""
    pan_resolution: float
    """Arc-seconds per position, as ``PR`` prints it."""
    tilt_resolution: float
    pan_min: int
    pan_max: int
    tilt_min: int
    tilt_max: int
    base_speed: int = 1000
    accel: int = 2000
    speed: int = 1000
    """Desired speed at power-up."""
    upper_speed: int = 2902
    lower_speed: int = 31
    hard_stop_margin: int = 40
    """Positions between a soft limit and the mechanical stop."""
    version: str = (
        "Pan-Tilt Controller v2.12.1d1(C14/E), (C)2003 Directed Perception, Inc., "
        "All Rights Reserved"
    )
    illegal_message: str = "Illegal Command Entered"
    """The D46's own wording is not documented; this is the D48E's."""


MODELS: dict[str, PtuModel] = {
    # PTU-D46 User's Manual v2.14.0 examples.
    "D46-17": PtuModel("D46-17", True, 185.1428, 185.1428, -3090, 3090, -907, 604),
    # 4x finer gearing; resolution, range and top speed (~60 deg/s) are not from a manual.
    "46-70": PtuModel(
        "46-70",
        False,
        46.2857,
        46.2857,
        -12360,
        12360,
        -3628,
        2416,
        upper_speed=4667,
        hard_stop_margin=160,
    ),
}
