"""A simulated camera on the PTU: renders what it would see from a scene panorama.

The panorama is equirectangular: column ↔ pan, row ↔ tilt, linearly, over a known
angular extent. Each frame is rendered through the exact pinhole/pan-tilt geometry of
:mod:`daemon.ptu.geometry` at the pose the PTU reports at grab time, so motion and
pointing errors show up in the frames, then gets sensor noise. The built-in scene is
:func:`daemon.scene.outcrop_scene` at panorama size: a layered cliff with ledge
shadows and planted targets (wet stain, plant, white vein knot, red spot) whose world
angles are known, which is what tests and the survey benchmark score against.
``sim://world`` (the demo's) instead draws each frame from :class:`daemon.world.World`, a
procedural outcrop with detail at every range, at the ground resolution of the view.

A panorama has edges; the camera invents no pixels beyond them. It states what it shows
(:attr:`SimulatedCamera.extent`), so a survey plan reaching further is refused before
anything moves, and a frame that still looks past an edge (a chip at a mosaic's border, the
operator jogging the head) shows :data:`NO_DATA` there, not a smear of the border pixels.
"""

from __future__ import annotations

import asyncio
import functools
import time
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

import cv2
import numpy as np

from ..pointing.geometry import CameraModel, pixel_centre, pixel_index, pixel_to_angles
from ..sim.scene import outcrop_scene
from ..sim.world import World
from ..vision.imageio import ImageError, as_bgr8, read_image
from .base import Camera, CameraError, Exposure, Frame, PoseSource

__all__ = [
    "NO_DATA",
    "Panorama",
    "PoseSource",
    "SimulatedCamera",
    "WorldTarget",
    "outcrop_panorama",
]

PAN, TILT = (-50.0, 50.0), (-26.0, 26.0)
"""Default extent of a panorama, degrees (min, max): the built-in cliff's, and what a file
spans unless its URL says: room for the default 2x3 mosaic of a 30 deg camera at pan 0, tilt
0, which reaches pan +-46.0 and tilt +-24.2."""
NO_DATA = (0, 0, 0)
"""BGR of a pixel looking beyond the panorama: exactly black, without sensor noise."""


@dataclass(frozen=True)
class WorldTarget:
    """A planted feature's kind and where it is, in world degrees."""

    kind: str
    pan: float
    tilt: float
    radius: float


@dataclass(frozen=True)
class Panorama:
    """An equirectangular scene: ``image`` spans ``pan`` and ``tilt`` (degrees, min..max)."""

    image: np.ndarray
    pan: tuple[float, float]
    tilt: tuple[float, float]
    targets: tuple[WorldTarget, ...] = ()

    @property
    def pixels_per_degree(self) -> tuple[float, float]:
        h, w = self.image.shape[:2]
        return w / (self.pan[1] - self.pan[0]), h / (self.tilt[1] - self.tilt[0])

    def to_pixel(self, pan, tilt):
        """Continuous panorama (x, y) of world angles (row 0 is the top, the highest tilt)."""
        px, py = self.pixels_per_degree
        return (np.asarray(pan) - self.pan[0]) * px, (self.tilt[1] - np.asarray(tilt)) * py


@functools.lru_cache(maxsize=4)
def outcrop_panorama(
    seed: int,
    pan: tuple[float, float] = PAN,
    tilt: tuple[float, float] = TILT,
    pixels_per_degree: float = 24.0,
    n_targets: int = 4,
) -> Panorama:
    """The built-in cliff, cached: a few seconds at the default 2400×1248 pixels."""
    w = round((pan[1] - pan[0]) * pixels_per_degree)
    h = round((tilt[1] - tilt[0]) * pixels_per_degree)
    scene = outcrop_scene(seed, shape=(h, w), n_targets=n_targets, tiles=(1, 1))
    targets = tuple(
        WorldTarget(
            t.kind,
            pan[0] + t.x / pixels_per_degree,
            tilt[1] - t.y / pixels_per_degree,
            t.radius / pixels_per_degree,
        )
        for t in scene.targets
    )
    image = scene.image
    image.setflags(write=False)
    return Panorama(image, pan, tilt, targets)


@dataclass(frozen=True)
class _Maps:
    """One pose's pixel directions: world degrees (the world) or panorama pixels, and the
    pixels looking beyond the panorama (None: none do)."""

    key: tuple[float, float, float]
    a: np.ndarray
    b: np.ndarray
    beyond: np.ndarray | None


class SimulatedCamera(Camera):
    """Frames of a panorama seen from the PTU's live pose.

    ``pose`` is awaited at every grab (typically ``PanTiltUnit.position``); without one,
    the camera looks where :attr:`fixed_pose` says.
    """

    def __init__(
        self,
        panorama: Panorama | World,
        camera: CameraModel | None = None,
        *,
        pose: PoseSource | None = None,
        noise: float = 2.0,
        seed: int = 0,
    ) -> None:
        self.panorama = panorama
        self.model = camera or CameraModel()
        self._wide_hfov = self.model.hfov
        self.pose_source = pose
        self.fixed_pose = (0.0, 0.0)
        self.noise = noise
        self._rng = np.random.default_rng(seed)
        self._seq = 0
        self._maps: _Maps | None = None

    @property
    def resolution(self) -> tuple[int, int]:
        return self.model.width, self.model.height

    @property
    def hfov(self) -> float:
        return self._wide_hfov

    @property
    def extent(self) -> tuple[tuple[float, float], tuple[float, float]] | None:
        """The panorama's (pan, tilt) ranges; None for the world, which has no edge."""
        if isinstance(self.panorama, Panorama):
            return self.panorama.pan, self.panorama.tilt
        return None

    async def open(self) -> None:
        return None

    async def close(self) -> None:
        return None

    @property
    def has_zoom(self) -> bool:
        return True

    async def zoom(self, level: float) -> float:
        """Narrow the field of view ``level`` times (1 = widest), as a zoom lens would,
        at once."""
        if not level >= 1.0:
            raise ValueError(f"zoom level must be >= 1, got {level!r}")
        wide = CameraModel(self.model.width, self.model.height, self._wide_hfov)
        self.model = wide.zoomed(level)
        self._maps = None
        return 0.0

    def _directions(self, pan: float, tilt: float) -> _Maps:
        """World (pan, tilt) of every pixel centre at this pose, or where in the panorama
        they fall (remap samples pixel centres at integer coordinates) and which fall
        beyond it; cached per pose."""
        key = (pan, tilt, self.model.hfov)
        if self._maps is None or self._maps.key != key:
            w, h = self.resolution
            xs = pixel_centre(np.arange(w, dtype=np.float64))
            ys = pixel_centre(np.arange(h, dtype=np.float64))
            a, b = pixel_to_angles(xs[None, :], ys[:, None], pan, tilt, self.model)
            beyond = None
            if isinstance(self.panorama, Panorama):
                (p0, p1), (t0, t1) = self.panorama.pan, self.panorama.tilt
                beyond = (a < p0) | (a > p1) | (b < t0) | (b > t1)
                px, py = self.panorama.to_pixel(a, b)
                a, b = pixel_index(px).astype(np.float32), pixel_index(py).astype(np.float32)
            self._maps = _Maps(key, a, b, beyond if beyond is not None and beyond.any() else None)
        return self._maps

    def render(self, pan: float, tilt: float) -> np.ndarray:
        """The noiseless view at (pan, tilt) degrees."""
        maps = self._directions(pan, tilt)
        if isinstance(self.panorama, World):  # drawn at the detail this view resolves
            return self.panorama.render(maps.a, maps.b, self.model.degrees_per_pixel)
        # Replicating covers only the outer half of the border pixels, which the panorama
        # spans; beyond its edge nothing is invented.
        image = cv2.remap(
            self.panorama.image, maps.a, maps.b, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE
        )
        if maps.beyond is not None:
            image[maps.beyond] = NO_DATA
        return image

    async def grab(self) -> Frame:
        pan, tilt = await self.pose_source() if self.pose_source else self.fixed_pose
        image = await asyncio.to_thread(self._expose, pan, tilt)
        self._seq += 1
        return Frame(image, time.time(), self._seq, Exposure(1 / 250, 0.0, False), (pan, tilt))

    def _expose(self, pan: float, tilt: float) -> np.ndarray:
        image = self.render(pan, tilt)
        if self.noise > 0:
            noise = self._rng.normal(0.0, self.noise, image.shape).astype(np.float32)
            image = cv2.add(image, noise, dtype=cv2.CV_8U)
            beyond = self._directions(pan, tilt).beyond
            if beyond is not None:
                image[beyond] = NO_DATA
        return image

    @classmethod
    def from_url(cls, url: str, pose: PoseSource | None = None, zoom: str = "") -> SimulatedCamera:
        """``sim://outcrop?seed=N``, ``sim://world?seed=N`` (:class:`daemon.world.World`,
        detail at every range) or ``sim:///path/pano.png?pan=-50,50&tilt=-26,26``; ``pose``
        says where the PTU points, ``zoom`` is unused (this camera zooms itself).

        All take ``hfov`` (degrees), ``width``, ``height`` and ``noise`` (grey levels).
        """
        parts = urlsplit(url)
        q = {k: v[-1] for k, v in parse_qs(parts.query).items()}

        def span(name: str, default: tuple[float, float]) -> tuple[float, float]:
            if name not in q:
                return default
            lo, hi = (float(v) for v in q[name].split(","))
            if not lo < hi:
                raise ValueError(f"{name}={q[name]}: want min,max")
            return lo, hi

        pan, tilt = span("pan", PAN), span("tilt", TILT)
        panorama: Panorama | World
        if parts.netloc == "outcrop":
            panorama = outcrop_panorama(int(q.get("seed", 0)), pan, tilt)
        elif parts.netloc == "world":
            panorama = World(int(q.get("seed", 0)))
        elif parts.path:
            try:
                image = as_bgr8(read_image(Path(parts.path)))
            except ImageError as exc:
                raise CameraError(f"sim panorama {parts.path}: {exc}") from exc
            panorama = Panorama(image, pan, tilt)
        else:
            raise ValueError(f"sim camera URL names no scene: {url!r}")
        model = CameraModel(
            int(q.get("width", 720)), int(q.get("height", 576)), float(q.get("hfov", 30.0))
        )
        return cls(
            panorama, model, pose=pose, noise=float(q.get("noise", 2.0)), seed=int(q.get("seed", 0))
        )
