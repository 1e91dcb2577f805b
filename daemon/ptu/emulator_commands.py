"""The PTU-46 emulator's command table: name -> handler(emulator, argument or None) -> the
reply line, or None when the reply waits (``A``, ``R``) or there is nothing to say.

Each handler works on :class:`.emulator.Ptu46Emulator`'s state through its own helpers
(``_text``, ``_set_target``, ``_set_speed``, ...): the table is the emulator's, kept apart
from its clock, its byte parser and its motion.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .emulator import Ptu46Emulator, _AxisState

__all__ = ["HANDLERS"]


def _axis_of(letter: str) -> Callable[[Ptu46Emulator], _AxisState]:
    return (lambda e: e.pan) if letter == "P" else (lambda e: e.tilt)


def _position(letter: str):
    axis = _axis_of(letter)

    def handler(e: Ptu46Emulator, n: int | None) -> str:
        ax = axis(e)
        if n is None:
            return e._text(f"Current {ax.name} position is {ax.position}", ax.position)
        return e._set_target(ax, n)

    return handler


def _offset(letter: str):
    axis = _axis_of(letter)

    def handler(e: Ptu46Emulator, n: int | None) -> str:
        ax = axis(e)
        if n is None:
            target = ax.pending if ax.pending is not None else round(ax.motion.target)
            return e._text(f"Target {ax.name} position is {target}", target)
        return e._set_target(ax, ax.position + n)

    return handler


def _query(letter: str, verbose: str, value: Callable[[_AxisState], object]):
    axis = _axis_of(letter)

    def handler(e: Ptu46Emulator, n: int | None) -> str:
        if n is not None:
            return "! " + e.model.illegal_message
        ax = axis(e)
        return e._text(verbose.format(name=ax.name, v=value(ax)), value(ax))

    return handler


def _speed(letter: str):
    axis = _axis_of(letter)

    def handler(e: Ptu46Emulator, n: int | None) -> str:
        ax = axis(e)
        if n is None:
            v = round(ax.motion.speed)
            return e._text(f"Target {ax.name} speed is {v} positions/sec", v)
        return e._set_speed(ax, n)

    return handler


def _static_setting(letter: str, what: str, verbose: str, check: Callable[..., str | None]):
    """``PA``/``PB``/``PU``/``PL``: settings the unit cannot change while the axis moves."""
    axis = _axis_of(letter)

    def handler(e: Ptu46Emulator, n: int | None) -> str:
        ax = axis(e)
        current = round(
            getattr(ax.motion, what) if what in ("base", "accel") else getattr(ax, what)
        )
        if n is None:
            return e._text(verbose.format(name=ax.name, v=current), current)
        if ax.motion.moving:
            label = {"accel": "acceleration", "base": "base speed"}.get(what, f"{what} speed")
            return f"! {ax.name} {label} cannot be changed while the axis is moving"
        error = check(e, ax, n)
        if error:
            return error
        if what in ("base", "accel"):
            setattr(ax.motion, what, float(n))
        else:
            setattr(ax, what, n)
        return "*"

    return handler


def _check_accel(e: Ptu46Emulator, ax: _AxisState, n: int) -> str | None:
    return f"! {ax.name} acceleration must be positive" if n <= 0 else None


def _check_base(e: Ptu46Emulator, ax: _AxisState, n: int) -> str | None:
    if n > ax.upper:
        return f"! {ax.name} speed cannot exceed {ax.upper} positions/sec"
    return f"! Motor speed cannot be less than {ax.lower} pos/sec" if n < ax.lower else None


def _check_upper(e: Ptu46Emulator, ax: _AxisState, n: int) -> str | None:
    if n < ax.lower:
        return f"! Motor speed cannot be less than {ax.lower} pos/sec"
    cap = 2 * (e.model.upper_speed)
    return f"! {ax.name} speed cannot exceed {cap} positions/sec" if n > cap else None


def _check_lower(e: Ptu46Emulator, ax: _AxisState, n: int) -> str | None:
    if n < e.model.lower_speed:
        return f"! Motor speed cannot be less than {e.model.lower_speed} pos/sec"
    if n > ax.upper:
        return f"! {ax.name} speed cannot exceed {ax.upper} positions/sec"
    return None


def _flag(attr: str, value: bool):
    def handler(e: Ptu46Emulator, n: int | None) -> str:
        if n is not None:
            return "! " + e.model.illegal_message
        setattr(e, attr, value)
        return "*"

    return handler


def _flag_query(attr: str, on: str, off: str):
    def handler(e: Ptu46Emulator, n: int | None) -> str:
        return "* " + (on if getattr(e, attr) else off)

    return handler


def _halt(*letters: str):
    def handler(e: Ptu46Emulator, n: int | None) -> str:
        for ax in (e.pan, e.tilt):
            if ax.letter in letters:
                ax.pending = None
                ax.motion.halt()
        return "*"

    return handler


def _power(letter: str, kind: str, level: str | None):
    axis = _axis_of(letter)
    attr = "hold_power" if kind == "hold" else "move_power"

    def handler(e: Ptu46Emulator, n: int | None) -> str:
        ax = axis(e)
        if level is None:
            return f"* {ax.name} in {getattr(ax, attr)} {kind} power mode"
        setattr(ax, attr, level)
        return "*"

    return handler


def _defaults(action: str):
    def handler(e: Ptu46Emulator, n: int | None) -> str:
        if action == "save":
            e._saved = e._snapshot()
        else:
            e._restore(e._saved if action == "restore" else e._factory)
        return "*"

    return handler


def _unit(e: Ptu46Emulator, n: int | None) -> str:
    if n is None:
        return e._text(f"Unit ID is {e._unit_id}", e._unit_id)
    if not 0 <= n <= 127:
        return f"! Unit ID must be between 0 and 127, not {n}"
    e._unit_id = n
    return "*"


def _select(e: Ptu46Emulator, n: int | None) -> None:
    """``_n`` selects a unit on a multi-drop line; unselected units stay silent."""
    e._selected = n is None or n in (0, e._unit_id)


HANDLERS: dict[str, Callable[..., object]] = {
    "A": lambda e, n: e._await_motion(),
    "I": _flag("immediate", True),
    "S": _flag("immediate", False),
    "IQ": _flag_query("immediate", "Immediate execution mode", "Slaved execution mode"),
    "H": _halt("P", "T"),
    "HP": _halt("P"),
    "HT": _halt("T"),
    "L": _flag_query(
        "limits",
        "Limit bounds are ENABLED (soft limits enabled)",
        "Limit bounds are DISABLED (hard limits only: use care)",
    ),
    "LE": _flag("limits", True),
    "LD": _flag("limits", False),
    "E": _flag_query("echo", "Echoing ON", "Echoing OFF"),
    "EE": _flag("echo", True),
    "ED": _flag("echo", False),
    "F": _flag_query("verbose", "ASCII verbose mode", "ASCII terse mode"),
    "FV": _flag("verbose", True),
    "FT": _flag("verbose", False),
    "C": _flag_query(
        "velocity_mode",
        "pure velocity speed control mode",
        "independent (default) speed control mode",
    ),
    "CI": _flag("velocity_mode", False),
    "CV": _flag("velocity_mode", True),
    "R": lambda e, n: e._calibrate(),
    "RD": lambda e, n: "*",
    "RE": lambda e, n: "*",
    "RP": lambda e, n: "*",
    "RT": lambda e, n: "*",
    "DS": _defaults("save"),
    "DR": _defaults("restore"),
    "DF": _defaults("factory"),
    "V": lambda e, n: "* " + e.model.version,
    "O": lambda e, n: e._text("Input 12 VDC @ 77 degF", "12,77"),
    "U": _unit,
    "_": _select,
}
for _l in "PT":
    HANDLERS |= {
        f"{_l}P": _position(_l),
        f"{_l}O": _offset(_l),
        f"{_l}S": _speed(_l),
        f"{_l}R": _query(_l, "{v:.4f} seconds arc per {name} position", lambda a: a.resolution),
        f"{_l}N": _query(_l, "Minimum {name} position is {v}", lambda a: a.lo),
        f"{_l}X": _query(_l, "Maximum {name} position is {v}", lambda a: a.hi),
        f"{_l}A": _static_setting(
            _l, "accel", "{name} acceleration is {v} positions/sec^2", _check_accel
        ),
        f"{_l}B": _static_setting(
            _l, "base", "Current {name} base speed is {v} positions/sec", _check_base
        ),
        f"{_l}U": _static_setting(
            _l, "upper", "Maximum {name} speed is {v} positions/sec", _check_upper
        ),
        f"{_l}L": _static_setting(
            _l, "lower", "Minimum {name} speed is {v} positions/sec", _check_lower
        ),
        f"{_l}H": _power(_l, "hold", None),
        f"{_l}HR": _power(_l, "hold", "REGULAR"),
        f"{_l}HL": _power(_l, "hold", "LOW"),
        f"{_l}HO": _power(_l, "hold", "OFF"),
        f"{_l}M": _power(_l, "move", None),
        f"{_l}MH": _power(_l, "move", "HIGH"),
        f"{_l}MR": _power(_l, "move", "REGULAR"),
        f"{_l}ML": _power(_l, "move", "LOW"),
    }
