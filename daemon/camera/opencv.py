"""Cameras OpenCV can open: a V4L2 device, a video file, a GStreamer pipeline.

A FireWire DV camcorder is not a V4L2 device: pipe it in, e.g. ``dvgrab -format raw - |
ffmpeg -i - -f v4l2 /dev/video10`` (v4l2loopback) or, with an OpenCV built against
GStreamer, ``gst://dv1394src ! dvdemux ! dvdec ! videoconvert ! appsink``.
"""

from __future__ import annotations

import asyncio
import logging
import time
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

import cv2
import numpy as np

from cyborg.protocol.redact import redact_url

from .base import Camera, CameraError, CameraUnavailableError, Exposure, Frame
from .visca import ViscaError, ViscaZoom

__all__ = ["OpenCvCamera", "parse_source"]

_LOGGER = logging.getLogger(__name__)


def parse_source(url: str) -> tuple[int | str, int, bool]:
    """``(source, api preference, loop)`` for a camera URL.

    >>> parse_source("v4l2://2"), parse_source("file:///tmp/a.avi?loop=1")
    ((2, 200, False), ('/tmp/a.avi', 0, True))
    >>> parse_source("gst://videotestsrc ! appsink")[1] == cv2.CAP_GSTREAMER
    True
    """
    parts = urlsplit(url)
    loop = parse_qs(parts.query).get("loop", ["0"])[-1] not in ("0", "")
    if parts.scheme == "v4l2":
        return int(parts.netloc or parts.path.strip("/") or 0), cv2.CAP_V4L2, False
    if parts.scheme == "file":
        return parts.path, cv2.CAP_ANY, loop
    if parts.scheme == "gst":
        return url[len("gst://") :], cv2.CAP_GSTREAMER, False
    if url.isdigit():
        return int(url), cv2.CAP_ANY, False
    return url, cv2.CAP_ANY, False


class OpenCvCamera(Camera):
    """``cv2.VideoCapture`` off the event loop, reopened after a failed read."""

    def __init__(
        self,
        source: int | str,
        api: int = cv2.CAP_ANY,
        *,
        loop: bool = False,
        retries: int = 3,
        backoff: float = 0.2,
        zoom: ViscaZoom | None = None,
    ) -> None:
        """``zoom``: the lens's zoom, driven on its own line (VISCA)."""
        self.source = source
        self.name = redact_url(str(source))
        """The source as messages and logs show it: no credentials."""
        self.lens = zoom
        self.api = api
        self.loop = loop
        self.retries = retries
        self.backoff = backoff
        self._cap: cv2.VideoCapture | None = None
        self._lock = asyncio.Lock()
        self._size = (0, 0)
        self._seq = 0
        self.reconnects = 0

    @classmethod
    def from_url(cls, url: str, pose: object = None, zoom: str = "") -> OpenCvCamera:
        """The camera :func:`parse_source` reads from ``url``, with the lens's zoom line
        ``zoom`` if named (``visca:///dev/ttyUSB1?max=30``); ``pose`` is for simulated
        cameras, unused here."""
        source, api, loop = parse_source(url)
        return cls(source, api, loop=loop, zoom=ViscaZoom.from_url(zoom) if zoom else None)

    @property
    def resolution(self) -> tuple[int, int]:
        return self._size

    def _is_file(self) -> bool:
        return isinstance(self.source, str) and Path(self.source).is_file()

    def _open_blocking(self) -> cv2.VideoCapture:
        src = self.source
        if isinstance(src, str) and "!" not in src and "://" not in src and not Path(src).exists():
            raise CameraUnavailableError(f"camera {src}: no such file or device")
        cap = cv2.VideoCapture(self.source, self.api)
        if not cap.isOpened():
            cap.release()
            raise CameraUnavailableError(f"camera {self.name}: OpenCV cannot open it")
        return cap

    async def open(self) -> None:
        async with self._lock:
            await self._reopen()
        if self.lens is not None:
            try:
                await self.lens.open()
            except ViscaError as exc:
                raise CameraUnavailableError(f"zoom: {exc}") from exc

    @property
    def has_zoom(self) -> bool:
        return self.lens is not None

    async def zoom(self, level: float) -> float:
        if self.lens is None:
            return 0.0
        try:
            return await self.lens.set_level(level)
        except ViscaError as exc:
            raise CameraError(f"zoom: {exc}") from exc

    async def _reopen(self) -> None:
        await self._release()
        cap = await asyncio.to_thread(self._open_blocking)
        self._cap = cap
        self._size = (
            int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)),
            int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)),
        )

    async def _release(self) -> None:
        cap, self._cap = self._cap, None
        if cap is not None:
            await asyncio.to_thread(cap.release)

    async def close(self) -> None:
        async with self._lock:
            await self._release()
        if self.lens is not None:
            await self.lens.close()

    def _read_blocking(self) -> np.ndarray | None:
        cap = self._cap
        if cap is None:
            return None
        ok, image = cap.read()
        if not ok and self.loop and self._is_file():
            cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
            ok, image = cap.read()
        return image if ok else None

    def _exposure(self) -> Exposure:
        cap = self._cap
        if cap is None or self._is_file():
            return Exposure()
        exposure, gain = cap.get(cv2.CAP_PROP_EXPOSURE), cap.get(cv2.CAP_PROP_GAIN)
        auto = cap.get(cv2.CAP_PROP_AUTO_EXPOSURE)
        return Exposure(exposure or None, gain or None, None if auto == 0 else auto != 1)

    async def grab(self) -> Frame:
        async with self._lock:
            image = await asyncio.to_thread(self._read_blocking)
            attempt = 0
            while image is None:
                if attempt >= self.retries:
                    raise CameraUnavailableError(
                        f"camera {self.name}: no frame after {attempt} reconnect attempt(s)"
                    )
                attempt += 1
                _LOGGER.warning("camera %s: read failed, reconnecting (%d)", self.name, attempt)
                await asyncio.sleep(self.backoff * attempt)
                try:
                    await self._reopen()
                except CameraUnavailableError as exc:
                    _LOGGER.debug("%s", exc)
                    continue
                self.reconnects += 1
                image = await asyncio.to_thread(self._read_blocking)
            if image.ndim == 2:
                image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
            self._size = (image.shape[1], image.shape[0])
            self._seq += 1
            return Frame(image, time.time(), self._seq, self._exposure())
