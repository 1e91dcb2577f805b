"""zenoh's own log, through our logging: a TLS handshake refused, a link lost, an access
denied are explained there, and a field log must not need a second place to look.

zenoh-python 1.x has no bridge to Python's logging: ``zenoh.init_log_from_env_or`` writes
formatted lines to file descriptor 1. :func:`route_zenoh_logs` points fd 1 at a pipe, a
thread parses each line and logs it under ``zenoh.<target>`` at its level, and Python's
own ``sys.stdout`` moves to a copy of the real stdout, so nothing else changes.
``RUST_LOG``, when set, overrides the level (zenoh's rule).
"""

from __future__ import annotations

import logging
import os
import re
import sys
import threading
from typing import TextIO

import zenoh

__all__ = ["route_zenoh_logs"]

_LINE = re.compile(
    r"^\S+\s+(?P<level>TRACE|DEBUG|INFO|WARN|ERROR)\s+(?:\S+\s+)?ThreadId\(\d+\)\s+"
    r"(?P<target>[\w:]+):\s?(?P<text>.*)$"
)
_LEVELS = {
    "TRACE": logging.DEBUG,
    "DEBUG": logging.DEBUG,
    "INFO": logging.INFO,
    "WARN": logging.WARNING,
    "ERROR": logging.ERROR,
}
_EXPECTED = ("Gossip is disabled", "Can not create a new UnixSocketStream link bound to")
"""Warnings about choices made on purpose (scouting and gossip are off: endpoints are
explicit) or about nothing (printed for every unix-socket client that connects fine),
logged at DEBUG instead."""


def route_zenoh_logs(level: str = "warn") -> TextIO:
    """Start routing; returns the stream that is now the process's real stdout. Call once,
    before the first zenoh session opens."""
    os.environ.setdefault("NO_COLOR", "1")  # tracing's formatter: no ANSI escapes
    sys.stdout.flush()
    real = os.dup(1)
    read, write = os.pipe()
    os.dup2(write, 1)
    os.close(write)
    sys.stdout = os.fdopen(real, "w", buffering=1)
    zenoh.init_log_from_env_or(level)
    threading.Thread(target=_pump, args=(read,), name="cyborgd.zenoh.log", daemon=True).start()
    return sys.stdout


def _pump(fd: int) -> None:
    root = logging.getLogger("zenoh")
    with os.fdopen(fd, "r", errors="replace") as lines:
        for raw in lines:
            line = raw.rstrip()
            m = _LINE.match(line)
            if m is None:
                if line:
                    root.info("%s", line)
                continue
            text = m["text"]
            level = _LEVELS[m["level"]]
            if level == logging.WARNING and text.startswith(_EXPECTED):
                level = logging.DEBUG
            root.getChild(m["target"].replace("::", ".")).log(level, "%s", text)
