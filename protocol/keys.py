"""Every zenoh key expression of the rig, built here and only here.

All keys live under ``cyborg/<rig>/``. Telemetry is published by the rig alone; commands
are queries on ``cmd/<client>/<verb>`` that the rig answers. The ``<client>`` segment is
the caller's identity: an access-control list lets each principal query only its own
segment, and the rig binds control to that name (protocol 2).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .errors import InvalidFieldError
from .messages import REQUESTS

__all__ = ["COMMANDS", "Keys", "check_client"]

_RIG = re.compile(r"[A-Za-z0-9_-]{1,64}\Z")
_CLIENT = re.compile(r"[A-Za-z0-9._-]{1,64}\Z")

COMMANDS = tuple(REQUESTS)
"""Every command verb, from the request classes (``protocol.messages.REQUESTS``)."""


def check_client(name: str) -> str:
    """``name`` if it is a valid client name (1-64 of letters, digits, '.', '_', '-'):
    printable, one key segment, no wildcard, nothing a log or a page could misread.

    >>> check_client("alice.field-1")
    'alice.field-1'
    >>> check_client("al ice")
    Traceback (most recent call last):
    ...
    protocol.errors.InvalidFieldError: client name 'al ice': use 1-64 letters, digits, ...
    """
    if not isinstance(name, str) or not _CLIENT.match(name) or name in (".", ".."):
        shown = repr(name[:40] + "…" if isinstance(name, str) and len(name) > 40 else name)
        raise InvalidFieldError(
            f"client name {shown}: use 1-64 letters, digits, '.', '_' or '-' (nothing else)"
        )
    return name


@dataclass(frozen=True)
class Keys:
    """The key space of one rig.

    >>> k = Keys("rig1")
    >>> k.frame, k.cmd("alice", "ptu/goto"), k.alive
    ('cyborg/rig1/cam/frame', 'cyborg/rig1/cmd/alice/ptu/goto', 'cyborg/rig1/alive')
    >>> k.command_of("cyborg/rig1/cmd/alice/ptu/goto")
    ('alice', 'ptu/goto')
    """

    rig: str

    def __post_init__(self) -> None:
        if not _RIG.match(self.rig):
            raise ValueError(f"rig name {self.rig!r}: use 1-64 letters, digits, '_' or '-'")

    @property
    def root(self) -> str:
        return f"cyborg/{self.rig}"

    @property
    def frame(self) -> str:
        return f"{self.root}/cam/frame"

    def stream(self, name: str) -> str:
        """A live view at its own rate, size and quality (``StreamRequest.name``)."""
        return f"{self.frame}/{name}"

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

    @property
    def telemetry(self) -> tuple[str, ...]:
        """Every key the rig publishes on (only the rig may)."""
        return (self.frame, self.ptu_state, self.progress, self.result, self.chip, self.events)

    def cmd(self, client: str, verb: str) -> str:
        if verb not in COMMANDS:
            raise ValueError(f"unknown command {verb!r}")
        return f"{self.root}/cmd/{check_client(client)}/{verb}"

    def commands_of(self, client: str) -> str:
        """Every command key of one client (what an access-control list grants it)."""
        return f"{self.root}/cmd/{check_client(client)}/**"

    @property
    def all_commands(self) -> str:
        return f"{self.root}/cmd/**"

    def command_of(self, key: str) -> tuple[str, str] | None:
        """(client, verb) of a received command key; the client segment is not yet
        checked (the rig refuses a bad one with a reason), the verb may be unknown."""
        prefix = f"{self.root}/cmd/"
        if not key.startswith(prefix):
            return None
        client, _, verb = key[len(prefix) :].partition("/")
        return client, verb
