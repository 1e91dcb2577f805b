"""Cameras, chosen by URL.

=====================================  ====================================================
``v4l2://0``                           a V4L2 device by index
``file:///data/pass1.avi?loop=1``      a video file (``loop`` rewinds at the end)
``gst://dv1394src ! ... ! appsink``    a GStreamer pipeline (OpenCV built with GStreamer)
``/dev/video2``, ``clip.mp4``          a bare path
``sim://outcrop?seed=7&hfov=30``       the simulated camera on the PTU, built-in cliff
``sim:///data/pano.png?pan=-40,40``    the simulated camera on your own panorama
=====================================  ====================================================
"""

from __future__ import annotations

from .base import Camera, CameraError, CameraUnavailableError, Exposure, Frame
from .opencv import OpenCvCamera, parse_source
from .simulated import Panorama, PoseSource, SimulatedCamera, WorldTarget, outcrop_panorama

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


def open_camera(url: str, pose: PoseSource | None = None) -> Camera:
    """Build (not open) the camera a URL names; ``pose`` feeds simulated cameras.

    >>> type(open_camera("v4l2://0")).__name__
    'OpenCvCamera'
    """
    if url.startswith("sim://"):
        return SimulatedCamera.from_url(url, pose)
    source, api, loop = parse_source(url)
    return OpenCvCamera(source, api, loop=loop)
