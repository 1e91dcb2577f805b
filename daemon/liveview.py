"""The live views: the default one (``[frames]``, full size) and the streams clients ask
for to fit their link (``cam/stream``: a rate, a width, a JPEG quality).

A stream is published on its own key while anybody subscribes there; clients asking the
same settings share it. One grab serves every view due at that moment, each encoded at its
own size and quality. A stream nobody has watched for :data:`IDLE_S` is forgotten.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from cyborg.protocol.keys import Keys
from cyborg.protocol.messages import FrameStream, StreamRequest

from .vision.imageio import encode_image

__all__ = ["IDLE_S", "LiveViews", "View"]

IDLE_S = 30.0
"""A stream asked for but not watched (or no longer) is dropped after this long."""
MAX_STREAMS = 16
"""Distinct streams at once: each costs an encode per frame (the oldest idle goes first)."""


@dataclass
class View:
    key: str
    period: float
    width: int | None
    """None: the camera's own size."""
    quality: int
    next_at: float = 0.0
    idle_since: float | None = None

    def encode(self, image: np.ndarray) -> tuple[bytes, int, int] | None:
        """This view's JPEG of ``image`` (reduced to its width) with its width and height,
        or None if encoding failed."""
        rows, cols = image.shape[:2]
        if self.width is not None and cols > self.width:
            size = (self.width, max(1, round(rows * self.width / cols)))
            image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
        jpeg = encode_image(image, quality=self.quality)
        return (jpeg, image.shape[1], image.shape[0]) if jpeg else None


class LiveViews:
    """Which views are due, given which are watched (``watched(key)``)."""

    def __init__(
        self, keys: Keys, rate: float, quality: int, watched: Callable[[str], bool]
    ) -> None:
        self.keys = keys
        self.watched = watched
        self.default = View(keys.frame, 1.0 / rate, None, quality) if rate > 0 else None
        self.streams: dict[str, View] = {}
        self.dropped: list[str] = []
        """Keys of streams forgotten since the last look (their publishers can go)."""

    def ask(self, req: StreamRequest) -> FrameStream:
        key = self.keys.stream(req.name)
        if key not in self.streams:
            if len(self.streams) >= MAX_STREAMS:
                oldest = min(self.streams.values(), key=lambda v: v.idle_since or time.monotonic())
                self._forget(oldest.key)
            view = View(key, 1.0 / req.fps, req.width, req.quality)
            view.idle_since = time.monotonic()  # until someone subscribes
            self.streams[key] = view
        return FrameStream(key, req.fps, req.width, req.quality)

    def due(self, now: float) -> list[View]:
        """The watched views whose next frame is due (their next time set), forgetting the
        streams idle too long."""
        out = []
        views = [self.default] if self.default is not None else []
        for view in [*views, *self.streams.values()]:
            if not self.watched(view.key):
                if view is not self.default:
                    view.idle_since = view.idle_since or now
                    if now - view.idle_since > IDLE_S:
                        self._forget(view.key)
                continue
            view.idle_since = None
            if now >= view.next_at:
                view.next_at += view.period
                if view.next_at <= now:  # late (or first): a period from now, no burst
                    view.next_at = now + view.period
                out.append(view)
        return out

    def next_wake(self, now: float, cap: float) -> float:
        """Seconds to sleep: until the next watched view is due, at most ``cap``.

        A view nobody watches is never due, and its next time stays in the past: counting
        it would make the frame loop spin, burning a core of the wearable's battery.
        """
        views = ([self.default] if self.default else []) + list(self.streams.values())
        watched = [v.next_at for v in views if self.watched(v.key)]
        soonest = min(watched, default=now + cap)
        return max(0.0, min(cap, soonest - now))

    def _forget(self, key: str) -> None:
        self.streams.pop(key, None)
        self.dropped.append(key)
