"""Cameras, chosen by URL.

=====================================  ====================================================
``v4l2://0``                           a V4L2 device by index
``file:///data/pass1.avi?loop=1``      a video file (``loop`` rewinds at the end)
``gst://dv1394src ! ... ! appsink``    a GStreamer pipeline (OpenCV built with GStreamer)
``/dev/video2``, ``clip.mp4``          a bare path
``sim://outcrop?seed=7&hfov=30``       the simulated camera on the PTU, built-in cliff
``sim:///data/pano.png?pan=-40,40``    the simulated camera on your own panorama
=====================================  ====================================================

A zoom lens on its own line is named apart (``[camera] zoom``), e.g.
``visca:///dev/ttyUSB1?max=30`` (:mod:`daemon.camera.visca`).
"""

from __future__ import annotations

from urllib.parse import parse_qs, urlsplit

from .base import Camera, CameraError, CameraUnavailableError, Exposure, Frame
from .opencv import OpenCvCamera, parse_source
from .simulated import Panorama, PoseSource, SimulatedCamera, WorldTarget, outcrop_panorama
from .visca import ViscaZoom

__all__ = [
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


def open_camera(url: str, pose: PoseSource | None = None, zoom: str = "") -> Camera:
    """Build (not open) the camera a URL names; ``pose`` feeds simulated cameras; ``zoom``
    names the lens's zoom line (``visca:///dev/ttyUSB1?max=30``; simulated cameras have
    their own).

    >>> type(open_camera("v4l2://0")).__name__
    'OpenCvCamera'
    >>> open_camera("v4l2://0", zoom="visca:///dev/ttyUSB1?max=20").lens.max_level
    20.0
    """
    if url.startswith("sim://"):
        return SimulatedCamera.from_url(url, pose)
    source, api, loop = parse_source(url)
    return OpenCvCamera(source, api, loop=loop, zoom=_zoom(zoom) if zoom else None)


def _zoom(url: str) -> ViscaZoom:
    parts = urlsplit(url)
    if parts.scheme != "visca" or not parts.path:
        raise ValueError(f"zoom {url!r}: want visca:///dev/ttyUSB1?max=30")
    query = parse_qs(parts.query)
    return ViscaZoom(
        parts.path,
        max_level=float(query.get("max", ["30"])[-1]),
        baudrate=int(query.get("baud", ["9600"])[-1]),
    )
