"""A scene as an ordinary camera delivers it: vignetting, a light gradient, slight defocus and
JPEG (``bench.quality --camera``; ``bench.real --jpeg`` uses the JPEG alone)."""

from __future__ import annotations

import dataclasses
from collections.abc import Collection

import cv2
import numpy as np

from .scene import Scene

__all__ = [
    "CAMERA_EFFECTS",
    "JPEG_QUALITY",
    "jpeg_quality",
    "jpeg_round_trip",
    "radial_undistort",
    "through_camera",
    "vignette",
]

CAMERA_EFFECTS = ("vignetting", "gradient", "defocus", "jpeg")
"""What :func:`through_camera` can do to a scene, in the order it does it."""
JPEG_QUALITY = (60, 90)
"""The JPEG quality range of :func:`through_camera`: a phone's or a rover's frames, not a
lossless archive."""


def jpeg_quality(quality: int) -> int:
    """``quality`` if it is a JPEG quality (1..100), else ValueError (OpenCV would clamp it
    silently)."""
    if not 1 <= quality <= 100:
        raise ValueError(f"JPEG quality is 1..100, got {quality}")
    return int(quality)


def jpeg_round_trip(image: np.ndarray, quality: int) -> np.ndarray:
    """``image`` (uint8, grey or BGR) as a camera's JPEG at ``quality`` delivers it, decoded
    again: 8-px blocks and, in colour, chroma at half resolution (4:2:0, as OpenCV writes
    it). Grey stays grey.

    >>> grey = np.tile(np.arange(64, dtype=np.uint8), (16, 1))
    >>> out = jpeg_round_trip(grey, 60)
    >>> out.shape, out.dtype.name, 0 < int(np.abs(out.astype(int) - grey).max()) < 16
    ((16, 64), 'uint8', True)
    >>> jpeg_round_trip(grey, 0)
    Traceback (most recent call last):
    ...
    ValueError: JPEG quality is 1..100, got 0
    """
    ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, jpeg_quality(quality)])
    if not ok:  # pragma: no cover - OpenCV always encodes a uint8 grey or BGR array
        raise RuntimeError("JPEG encoding failed")
    return cv2.imdecode(buf, cv2.IMREAD_UNCHANGED)


def vignette(rows: int, cols: int, corner: float) -> np.ndarray:
    """(rows, cols) float32 gain of a lens that is ``corner`` (0..1) darker at the image's
    corners than at its centre, falling off with the squared distance from the centre.

    >>> v = vignette(576, 720, 0.25)
    >>> round(float(v[288, 360]), 3), round(float(v[0, 0]), 3)
    (1.0, 0.751)
    """
    yy, xx = np.mgrid[0:rows, 0:cols].astype(np.float32)
    dx, dy = xx - (cols - 1) / 2.0, yy - (rows - 1) / 2.0
    half_diagonal = 0.5 * float(np.hypot(rows, cols))
    return 1.0 - corner * (dx * dx + dy * dy) / half_diagonal**2


def radial_undistort(x, y, k1: float, k2: float = 0.0):
    """Pinhole normalised coordinates (x, y divided by the focal length, from the optical
    centre) of distorted ones, under OpenCV's radial model ``x_d = x_u (1 + k1 r_u^2 +
    k2 r_u^4)``: what a lens with those coefficients shows at (x, y). Fixed-point
    iteration, exact to far below a pixel for the mild distortion of a camcorder's lens.

    >>> x, y = radial_undistort(0.3, -0.2, -0.1, 0.02)
    >>> r2 = x * x + y * y
    >>> [round(float(v * (1 - 0.1 * r2 + 0.02 * r2 * r2)), 9) for v in (x, y)]
    [0.3, -0.2]
    """
    xu, yu = x, y
    for _ in range(20):
        r2 = xu * xu + yu * yu
        factor = 1.0 + k1 * r2 + k2 * r2 * r2
        xu, yu = x / factor, y / factor
    return xu, yu


def through_camera(
    scene: Scene, effects: Collection[str] = CAMERA_EFFECTS, scale: float = 1.0
) -> Scene:
    """``scene`` as an ordinary camera delivers it: vignetting (15-35 % darker in the
    corners), a light gradient across the view (10-25 % over half the diagonal, any
    direction), slight defocus (Gaussian sigma 0.5-1.2 px) and JPEG at quality 60-90
    (chroma subsampled 4:2:0, as OpenCV writes it); ``effects`` names which. The scenes are
    otherwise rendered perfectly; a detector tuned on them alone may lean on what no real
    camera keeps.

    The camera is drawn from the scene's seed, whatever the effects, so two noisy looks at
    one scene go through the same camera and one effect alone is the one of the whole
    camera. Targets, labels and decoys are unchanged.

    ``scale`` > 1 is a camera whose frame is that many times finer on a side than what is
    analysed, as the rig's mosaics and a phone's photos are (``products.analyze_image``
    reduces them to its working size): the scene is rendered up (cubic), goes through the
    camera there (defocus in the camera's pixels) and is reduced back by area averaging.
    JPEG's blocks and its half-resolution colour then shrink by ``scale`` too.

    Examples
    --------
    >>> from cyborg.daemon.sim.scene import outcrop_scene
    >>> s = outcrop_scene(0, n_targets=0)          # an empty view
    >>> c = through_camera(s)
    >>> c.image.shape == s.image.shape, c.image.dtype.name, bool((c.image != s.image).any())
    (True, 'uint8', True)
    >>> bool((through_camera(s).image == c.image).all())   # deterministic by seed
    True
    >>> bool((through_camera(s, ()).image == s.image).all())
    True
    >>> through_camera(s, ("fisheye",))
    Traceback (most recent call last):
    ...
    ValueError: unknown camera effects ['fisheye']; choose from vignetting, gradient, defocus, jpeg
    >>> through_camera(s, ("jpeg",), scale=2.0).image.shape == s.image.shape
    True
    """
    unknown = sorted(set(effects) - set(CAMERA_EFFECTS))
    if unknown:
        raise ValueError(
            f"unknown camera effects {unknown}; choose from {', '.join(CAMERA_EFFECTS)}"
        )
    if not scale >= 1.0:  # also refuses NaN
        raise ValueError(
            f"a camera's scale is >= 1 (its frame over the analysed size), got {scale}"
        )
    rng = np.random.default_rng([scene.seed, 4])
    corner = rng.uniform(0.15, 0.35)
    angle, slope = rng.uniform(0.0, 2.0 * np.pi), rng.uniform(0.10, 0.25)
    sigma = rng.uniform(0.5, 1.2)
    quality = int(rng.integers(JPEG_QUALITY[0], JPEG_QUALITY[1] + 1))
    rows, cols = scene.image.shape[:2]
    img = scene.image.astype(np.float32)
    if scale > 1.0 and effects:
        size = (round(cols * scale), round(rows * scale))
        img = cv2.resize(img, size, interpolation=cv2.INTER_CUBIC)
    rows, cols = img.shape[:2]
    yy, xx = np.mgrid[0:rows, 0:cols].astype(np.float32)
    dx, dy = xx - (cols - 1) / 2.0, yy - (rows - 1) / 2.0
    half_diagonal = 0.5 * float(np.hypot(rows, cols))
    if "vignetting" in effects:
        img *= vignette(rows, cols, corner)[..., None]
    if "gradient" in effects:
        img *= (1.0 + slope * (dx * np.cos(angle) + dy * np.sin(angle)) / half_diagonal)[..., None]
    if "defocus" in effects:
        img = cv2.GaussianBlur(img, (0, 0), sigma)
    out = np.clip(img, 0, 255).astype(np.uint8)
    if "jpeg" in effects:
        out = jpeg_round_trip(out, quality)
    if out.shape != scene.image.shape:
        out = cv2.resize(out, scene.image.shape[1::-1], interpolation=cv2.INTER_AREA)
    return dataclasses.replace(scene, image=out)
