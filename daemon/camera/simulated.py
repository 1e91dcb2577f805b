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

The camera is ideal unless asked otherwise (:class:`Imperfections`): a real one's lens
distorts radially and darkens towards the corners, and its auto-exposure drifts from frame
to frame, following the scene's brightness with a lag. With them on, the tiles of a mosaic
no longer butt or blend by themselves, as on a real rig.

A panorama has edges; the camera invents no pixels beyond them. It states what it shows
(:attr:`SimulatedCamera.extent`), so a survey plan reaching further is refused before
anything moves, and a frame that still looks past an edge (a chip at a mosaic's border, the
operator jogging the head) shows :data:`NO_DATA` there, not a smear of the border pixels.
"""

from __future__ import annotations

import asyncio
import functools
import math
import time
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

import cv2
import numpy as np

from ..pointing.geometry import CameraModel, pixel_centre, pixel_index, pixel_to_angles
from ..sim.camera_effects import radial_undistort, vignette
from ..sim.scene import outcrop_scene
from ..sim.world import World
from ..vision.imageio import ImageError, as_bgr8, read_image
from .base import Camera, CameraError, Exposure, Frame, PoseSource

__all__ = [
    "AE_TARGET",
    "NO_DATA",
    "Imperfections",
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
AE_TARGET = 110.0
"""Mean grey level the simulated auto-exposure steers a frame towards."""


@dataclass(frozen=True)
class Imperfections:
    """What a real camera does to a view that the ideal simulated one does not; all off by
    default, drawn from the camera's seed.

    >>> Imperfections().enabled, Imperfections(k1=-0.1).enabled
    (False, True)
    >>> Imperfections.from_query({"vignetting": "0.3", "ae_lag": "0.5"})
    Imperfections(vignetting=0.3, k1=0.0, k2=0.0, ae_lag=0.5, ae_walk=0.0)
    """

    vignetting: float = 0.0
    """How much darker the corners are than the centre (0..1)."""
    k1: float = 0.0
    """Radial distortion, OpenCV's model on focal-normalised coordinates (< 0: barrel)."""
    k2: float = 0.0
    ae_lag: float = 0.0
    """Auto-exposure: the fraction (0..1] of the way from its last gain to the one that
    brings this frame's mean to :data:`AE_TARGET` that each frame goes; 0: fixed exposure."""
    ae_walk: float = 0.0
    """Rms per-frame random walk of the gain, in natural log units (0.03: about 3 %)."""

    def __post_init__(self) -> None:
        if not (0.0 <= self.vignetting < 1.0 and 0.0 <= self.ae_lag <= 1.0 and self.ae_walk >= 0):
            raise ValueError(f"want vignetting in [0, 1), ae_lag in [0, 1], ae_walk >= 0: {self}")

    @property
    def enabled(self) -> bool:
        return any((self.vignetting, self.k1, self.k2, self.ae_lag, self.ae_walk))

    @property
    def auto_exposure(self) -> bool:
        return self.ae_lag > 0.0 or self.ae_walk > 0.0

    @classmethod
    def from_query(cls, q: dict[str, str]) -> Imperfections:
        """From a camera URL's query (one value per name)."""
        return cls(**{f: float(q[f]) for f in cls.__dataclass_fields__ if f in q})


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
    the camera looks where :attr:`fixed_pose` says. ``imperfections`` make it a real camera.
    """

    def __init__(
        self,
        panorama: Panorama | World,
        camera: CameraModel | None = None,
        *,
        pose: PoseSource | None = None,
        noise: float = 2.0,
        seed: int = 0,
        imperfections: Imperfections = Imperfections(),
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
        self.imperfections = imperfections
        self._ae_rng = np.random.default_rng([seed, 45])
        self.gain: float | None = None
        """The auto-exposure's gain on the last frame (None before the first, or without AE)."""

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
            xs = pixel_centre(np.arange(w, dtype=np.float64))[None, :]
            ys = pixel_centre(np.arange(h, dtype=np.float64))[:, None]
            k1, k2 = self.imperfections.k1, self.imperfections.k2
            if k1 or k2:  # each pixel shows the ray its undistorted place would
                f, cx, cy = self.model.focal, w / 2.0, h / 2.0
                u, v = radial_undistort((xs - cx) / f, (ys - cy) / f, k1, k2)
                xs, ys = cx + f * u, cy + f * v
            a, b = pixel_to_angles(xs, ys, pan, tilt, self.model)
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
        exposure = Exposure(1 / 250, 0.0, False)
        if self.gain is not None:
            exposure = Exposure(1 / 250, 20.0 * math.log10(self.gain), True)
        return Frame(image, time.time(), self._seq, exposure, (pan, tilt))

    def _expose(self, pan: float, tilt: float) -> np.ndarray:
        image = self.render(pan, tilt)
        if self.imperfections.enabled:
            image = self._through_lens(image, self._directions(pan, tilt).beyond)
        if self.noise > 0:
            noise = self._rng.normal(0.0, self.noise, image.shape).astype(np.float32)
            image = cv2.add(image, noise, dtype=cv2.CV_8U)
            beyond = self._directions(pan, tilt).beyond
            if beyond is not None:
                image[beyond] = NO_DATA
        return image

    def _through_lens(self, image: np.ndarray, beyond: np.ndarray | None) -> np.ndarray:
        """Vignetting, then the auto-exposure's gain: it moves ``ae_lag`` of the way (in log)
        to the gain this frame's mean asks for, plus a random step of ``ae_walk``."""
        flaws = self.imperfections
        out = image.astype(np.float32)
        if flaws.vignetting:
            out *= vignette(*out.shape[:2], flaws.vignetting)[..., None]
        if flaws.auto_exposure:
            seen = out if beyond is None else out[~beyond]
            wanted = math.log(AE_TARGET / max(float(seen.mean()) if seen.size else 0.0, 1.0))
            if self.gain is None:  # settled on the first view before anyone asked
                log_gain = wanted if flaws.ae_lag else 0.0
            else:
                log_gain = math.log(self.gain) + flaws.ae_lag * (wanted - math.log(self.gain))
            self.gain = math.exp(log_gain + flaws.ae_walk * float(self._ae_rng.normal()))
            out *= self.gain
        out = np.clip(out + 0.5, 0, 255).astype(np.uint8)
        if beyond is not None:
            out[beyond] = NO_DATA
        return out

    @classmethod
    def from_url(cls, url: str, pose: PoseSource | None = None, zoom: str = "") -> SimulatedCamera:
        """``sim://outcrop?seed=N``, ``sim://world?seed=N`` (:class:`daemon.world.World`,
        detail at every range) or ``sim:///path/pano.png?pan=-50,50&tilt=-26,26``; ``pose``
        says where the PTU points, ``zoom`` is unused (this camera zooms itself).

        All take ``hfov`` (degrees), ``width``, ``height``, ``noise`` (grey levels) and a
        real camera's :class:`Imperfections`: ``vignetting`` (corners that much darker,
        0..1), ``k1``/``k2`` (radial distortion), ``ae_lag`` (auto-exposure following the
        scene, 0..1 of the way per frame) and ``ae_walk`` (its per-frame drift), e.g.
        ``sim://world?seed=3&vignetting=0.25&k1=-0.08&ae_lag=0.5&ae_walk=0.03``.
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
            panorama,
            model,
            pose=pose,
            noise=float(q.get("noise", 2.0)),
            seed=int(q.get("seed", 0)),
            imperfections=Imperfections.from_query(q),
        )
