"""One updating progress line on a terminal: k/N, rate, ETA (``cyborgd analyze``).

Drawn only where a person watches (the stream is a TTY); results and error lines are printed
above it, so it never mixes into what a pipe or a file receives.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TextIO

__all__ = ["Progress", "clock_text"]

_CLEAR = "\r\x1b[K"


def clock_text(seconds: float) -> str:
    """``m:ss`` or ``h:mm:ss``.

    >>> clock_text(65.4), clock_text(3725)
    ('1:05', '1:02:05')
    """
    s = round(seconds)
    h, m = divmod(s // 60, 60)
    return f"{h}:{m:02d}:{s % 60:02d}" if h else f"{m}:{s % 60:02d}"


class Progress:
    """``k/N images, R/s, ETA m:ss`` on one line of ``stream``, redrawn at most every
    ``interval`` seconds (a fast run would spend its time drawing otherwise) and at once
    after :meth:`clear`."""

    def __init__(
        self,
        total: int,
        stream: TextIO,
        interval: float = 0.25,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._total, self._stream, self._interval, self._clock = total, stream, interval, clock
        self._done = 0
        self._start = clock()
        self._drawn = -interval
        self._shown = False

    def line(self) -> str:
        """The text of the line now."""
        elapsed = self._clock() - self._start
        text = f"{self._done}/{self._total} images"
        if self._done and elapsed > 0:
            rate = self._done / elapsed
            eta = (self._total - self._done) / rate
            text += f", {rate:.1f}/s, ETA {clock_text(eta)}"
        return text

    def advance(self) -> None:
        """One more image finished (done, skipped or failed)."""
        self._done += 1
        now = self._clock()
        if not self._shown or self._done == self._total or now - self._drawn >= self._interval:
            self._drawn = now
            self._stream.write(_CLEAR + self.line())
            self._stream.flush()
            self._shown = True

    def clear(self) -> None:
        """Take the line away, so that other output starts at the margin."""
        if self._shown:
            self._stream.write(_CLEAR)
            self._stream.flush()
            self._shown = False

    def close(self) -> None:
        """Leave the final line on screen, ended."""
        if self._shown:
            self._stream.write("\n")
            self._stream.flush()
            self._shown = False
