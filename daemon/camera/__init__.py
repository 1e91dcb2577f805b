"""Cameras, chosen by URL.

=====================================  ====================================================
``v4l2://0``                           a V4L2 device by index
``file:///data/pass1.avi?loop=1``      a video file (``loop`` rewinds at the end)
``gst://dv1394src ! ... ! appsink``    a GStreamer pipeline (OpenCV built with GStreamer)
``/dev/video2``, ``clip.mp4``          a bare path
``sim://outcrop?seed=7&hfov=30``       the simulated camera on the PTU, built-in cliff
``sim://world?seed=7&hfov=30``         the same on a procedural world (detail at every range)
``sim:///data/pano.png?pan=-40,40``    the simulated camera on your own panorama
=====================================  ====================================================

A zoom lens on its own line is named apart (``[camera] zoom``), e.g.
``visca:///dev/ttyUSB1?max=30`` (:mod:`daemon.camera.visca`).

A backend is a :class:`Camera` with a ``from_url(url, pose, zoom)`` class method, named by a
row of :data:`BACKENDS` and imported when a URL first asks for it.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .base import Camera, CameraError, CameraUnavailableError, Exposure, Frame, PoseSource

if TYPE_CHECKING:
    from .opencv import OpenCvCamera
    from .simulated import Panorama, SimulatedCamera, WorldTarget, outcrop_panorama

__all__ = [
    "BACKENDS",
    "OTHERWISE",
    "Camera",
    "CameraError",
    "CameraUnavailableError",
    "Exposure",
    "Frame",
    "OpenCvCamera",
    "Panorama",
    "SimulatedCamera",
    "WorldTarget",
    "open_camera",
    "outcrop_panorama",
]

BACKENDS: dict[str, str] = {"sim": ".simulated:SimulatedCamera"}
"""URL scheme -> ``module:class`` of its backend (relative to this package), built by its
``from_url(url, pose, zoom)``."""
OTHERWISE = ".opencv:OpenCvCamera"
"""Every other URL (``v4l2://``, ``file://``, ``gst://``, a bare path) is OpenCV's."""

_LAZY = {
    "OpenCvCamera": ".opencv",
    "Panorama": ".simulated",
    "SimulatedCamera": ".simulated",
    "WorldTarget": ".simulated",
    "outcrop_panorama": ".simulated",
}
"""Back ends are imported when first used: a rig on a real camera never loads the simulator
(its scenes and world), nor a simulated one the VISCA driver."""


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def open_camera(url: str, pose: PoseSource | None = None, zoom: str = "") -> Camera:
    """Build (not open) the camera a URL names; ``pose`` feeds simulated cameras; ``zoom``
    names the lens's zoom line (``visca:///dev/ttyUSB1?max=30``; simulated cameras have
    their own).

    >>> type(open_camera("v4l2://0")).__name__
    'OpenCvCamera'
    >>> open_camera("v4l2://0", zoom="visca:///dev/ttyUSB1?max=20").lens.max_level
    20.0
    """
    scheme = url.partition("://")[0] if "://" in url else ""
    module, _, name = BACKENDS.get(scheme, OTHERWISE).partition(":")
    return getattr(importlib.import_module(module, __name__), name).from_url(url, pose, zoom)
