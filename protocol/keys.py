"""Every zenoh key expression of the rig, built here and only here.

All keys live under ``cyborg/<rig>/``. Telemetry is published; commands are queryables
under ``cmd/`` that answer an ``Ack``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = ["COMMANDS", "Keys"]

_NAME = re.compile(r"[A-Za-z0-9_-]{1,64}\Z")

COMMANDS = (
    "ptu/goto",
    "ptu/jog",
    "ptu/look",
    "ptu/halt",
    "ptu/home",
    "survey/start",
    "survey/cancel",
    "survey/status",
    "target/choose",
    "control/take",
    "control/release",
    "archive/list",
    "archive/get",
    "hello",
)


@dataclass(frozen=True)
class Keys:
    """The key space of one rig.

    >>> k = Keys("rig1")
    >>> k.frame, k.cmd("ptu/goto"), k.alive
    ('cyborg/rig1/cam/frame', 'cyborg/rig1/cmd/ptu/goto', 'cyborg/rig1/alive')
    """

    rig: str

    def __post_init__(self) -> None:
        if not _NAME.match(self.rig):
            raise ValueError(f"rig name {self.rig!r}: use 1-64 letters, digits, '_' or '-'")

    @property
    def root(self) -> str:
        return f"cyborg/{self.rig}"

    @property
    def frame(self) -> str:
        return f"{self.root}/cam/frame"

    @property
    def ptu_state(self) -> str:
        return f"{self.root}/ptu/state"

    @property
    def progress(self) -> str:
        return f"{self.root}/survey/progress"

    @property
    def result(self) -> str:
        return f"{self.root}/survey/result"

    @property
    def chip(self) -> str:
        return f"{self.root}/survey/chip"

    @property
    def events(self) -> str:
        return f"{self.root}/events"

    @property
    def alive(self) -> str:
        return f"{self.root}/alive"

    def cmd(self, name: str) -> str:
        if name not in COMMANDS:
            raise ValueError(f"unknown command {name!r}")
        return f"{self.root}/cmd/{name}"

    @property
    def all_commands(self) -> str:
        return f"{self.root}/cmd/**"

    def command_of(self, key: str) -> str | None:
        """The command name a received key expression addresses, if it is one of ours."""
        prefix = f"{self.root}/cmd/"
        name = key[len(prefix) :] if key.startswith(prefix) else None
        return name if name in COMMANDS else None
