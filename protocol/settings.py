"""A station's own parameter settings, ``NAME=VALUE``: their form on the wire and their
one spelling on every command line (``--set``).

What a name and a value mean is the rig's to judge (``daemon.vision.params.with_settings``);
this module checks only the form, so both sides (and every benchmark) agree on it.
"""

from __future__ import annotations

import argparse

from .base import clip

__all__ = ["MAX_SETTINGS", "add_settings_argument", "check_setting"]

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


def _setting(text: str) -> str:
    """argparse's reading of ``--set``: the form check, as a usage error."""
    try:
        return check_setting(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_settings_argument(
    parser: argparse._ActionsContainer,
    what: str,
    *,
    default: list[str] | None = None,
    otherwise: str = "",
) -> None:
    """``--set NAME=VALUE`` (repeatable, into ``settings``, each form-checked as it is read)
    for a command whose ``what`` (e.g. "the profile") it changes; ``otherwise`` says what
    applies when it is not given. Used by ``cyborgd analyze``, ``cyborg survey`` and the
    benchmarks alike."""
    parser.add_argument(
        "--set",
        action="append",
        type=_setting,
        default=default,
        metavar="NAME=VALUE",
        dest="settings",
        help=f"change a parameter of {what} (repeatable; names as in result.json's params), "
        "e.g. --set uncommon=surprisal" + (f"; {otherwise}" if otherwise else ""),
    )
