"""A procedural outcrop with detail at every range, rendered on demand.

The seed's approach (300 m, 60 m, 10 m) only means something if walking closer shows
something new. A stored panorama cannot: at 10 m it shows enlarged pixels. This world is a
function of direction (pan, tilt in degrees, as seen from the 300 m station; walking closer
along the line of sight is a narrower field of view onto the same directions) that is
evaluated at each pixel with the pixel's footprint, so every view gets the detail its ground
resolution can show and no more:

* beds with undulating contacts, lamination and grain: fractal noise in octaves from 2 deg
  down to 0.0005 deg (at 300 m, 10 m to 2.6 mm) that modulates the rock's reflectance, so it
  lightens and darkens a bed without greying its colour (``_ALBEDO``), each octave attenuated
  as a pixel of that footprint would average it (a Gaussian pixel of sigma = footprint / 2),
  so a coarse view is smooth rock, not aliased speckle;
* a planted wet stain whose structure resolves only close up: a darker, shadowed, bluish core
  (~10 % of its radius; 1-2 px at 300 m, tens of px at 10 m) and a bright efflorescence rim
  (1.5 % of its radius: invisible from afar);
* decoys at every scale: ledge shadows (lit by the sky alone, as every simulated shadow is:
  ``daemon.scene.SKY_SHADE``), a cluster of grey nodules (each 0.03 deg), a network of thin
  white veins (0.004 deg wide: a few grey pixels at 60 m, lines at 10 m);
* shapes are drawn with the coverage of a box pixel, so what is smaller than a pixel fades
  instead of flickering; the world has no edge (every direction is rock or sky).

Deterministic by seed; nothing is stored but a 256 x 256 noise tile.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from .scene import SKY_SHADE

__all__ = ["Feature", "World"]

_TILE = 256
_TEXELS = 4.0
"""Noise texels per octave wavelength (the tile is blurred to that grain)."""
_ALBEDO = 0.1
"""Amplitude of the coarsest grain octave, as a share of the rock's reflectance (each finer
octave has 0.82 of the one before). Grain is albedo: it scales all three channels of a bed.
Added as grey levels instead (14 on rock of ~140), it greyed coloured beds wherever it
lightened them and saturated them wherever it darkened them, a speckle of saturation no
rock shows, and the wet stain was the rig's 300 m #1 in 68 of 100 worlds, against 87 now
(``bench.approach --first-station 100``)."""
_LAMINAE = 0.043
"""Amplitude of the lamination, as a share of the reflectance (6 grey levels on ~140)."""
_SKYLINE = 30.0
"""Tilt of the skyline's mean, degrees (above it, sky)."""
_ROCKS = np.array(
    [(118, 158, 190), (70, 92, 158), (138, 140, 142), (196, 202, 208), (88, 92, 98),
     (72, 128, 172), (150, 168, 180)],
    np.float32,
)  # fmt: skip


@dataclass(frozen=True)
class Feature:
    """A planted feature in world degrees: its extent, and where its close-range detail is."""

    kind: str
    pan: float
    tilt: float
    radius: float
    close: tuple[float, float, float] | None = None
    """(pan, tilt, radius) of the detail only a close view resolves (the stain's core)."""


class World:
    """One seeded outcrop. :meth:`render` gives the view of any bundle of directions."""

    def __init__(self, seed: int) -> None:
        rng = np.random.default_rng([seed, 17])
        # Smoothed white noise that wraps seamlessly (blurred on a wrapped copy, cropped).
        pad = int(4 * _TEXELS)
        white = rng.standard_normal((_TILE, _TILE)).astype(np.float32)
        wrapped = cv2.copyMakeBorder(white, pad, pad, pad, pad, cv2.BORDER_WRAP)
        tile = cv2.GaussianBlur(wrapped, (0, 0), _TEXELS / 2.5)[pad:-pad, pad:-pad]
        self._tile = tile / float(tile.std())
        # Octaves: wavelength (deg), amplitude (share of the reflectance), rotation and offset
        # (texels).
        waves = 2.0 * 0.5 ** np.arange(13)  # 2 deg .. 0.0005 deg
        self._octaves = [
            (float(w), _ALBEDO * (0.82**i), rng.uniform(0, math.pi), rng.uniform(0, _TILE, 2))
            for i, w in enumerate(waves)
        ]
        self._beds = rng.uniform(1.5, 4.0, 40).cumsum() - 60.0  # bed tops, deg of tilt
        # One formation: beds of one rock, lighter and darker, a little warmer or cooler.
        base = _ROCKS[rng.integers(0, len(_ROCKS))]
        self._colours = base * rng.uniform(0.82, 1.12, (41, 1)) * rng.uniform(0.95, 1.05, (41, 3))
        self._undulation = [
            (rng.uniform(0.15, 0.45), rng.uniform(4.0, 18.0), rng.uniform(0, 2 * math.pi))
            for _ in range(3)
        ]
        self._lamination = rng.uniform(0.015, 0.04)
        self._seed = seed
        self.features = self._plant(rng)

    def _plant(self, rng: np.random.Generator) -> tuple[Feature, ...]:
        pan, tilt = rng.uniform(-12, 12), rng.uniform(-6, 4)
        radius = rng.uniform(1.2, 1.8)
        angle, off = rng.uniform(0, 2 * math.pi), rng.uniform(0, 0.35) * radius
        core = (pan + off * math.cos(angle), tilt + off * math.sin(angle), 0.1 * radius)
        stain = Feature("wet_stain", pan, tilt, radius, core)
        decoys = []
        for _ in range(int(rng.integers(3, 6))):
            where = rng.uniform((-25, -8), (25, 6))
            decoys.append(Feature("ledge_shadow", *where, rng.uniform(1.5, 4.0)))
        decoys.append(Feature("nodules", rng.uniform(-25, 25), rng.uniform(-8, 6), 0.35))
        decoys.append(Feature("veins", rng.uniform(-25, 25), rng.uniform(-8, 6), 0.8))
        # Decoys clear of the stain, so a point is never on both.
        kept = [d for d in decoys if math.hypot(d.pan - pan, d.tilt - tilt) > radius + d.radius]
        self._shadow_height = rng.uniform(0.2, 0.35, len(kept))
        self._nodules = rng.uniform(-1, 1, (24, 2))
        self._veins = rng.uniform(0, math.pi, 4)
        return (stain, *kept)

    @property
    def target(self) -> Feature:
        """The planted feature worth walking to."""
        return self.features[0]

    # -- rendering ---------------------------------------------------------------------------

    def render(self, pan: np.ndarray, tilt: np.ndarray, footprint: float) -> np.ndarray:
        """(M, N, 3) uint8 BGR of the directions (pan, tilt) (degrees, (M, N) arrays) seen by
        pixels ``footprint`` degrees wide."""
        pan = np.asarray(pan, np.float64)
        tilt = np.asarray(tilt, np.float64)
        fp = max(float(footprint), 1e-6)
        lift = sum(a * np.sin(2 * math.pi * pan / w + p) for a, w, p in self._undulation)
        level = tilt + lift
        index = np.searchsorted(self._beds, level).clip(0, len(self._colours) - 1)
        img = self._colours[index]
        wave = self._lamination
        lam = _LAMINAE * _attenuation(wave, fp) * np.sin(2 * math.pi * (level % wave) / wave)
        img *= (1.0 + self._grain(pan, tilt, fp) + lam.astype(np.float32))[..., None]
        for i, f in enumerate(self.features):
            box = _window(pan, tilt, f, fp)
            if box is not None:
                paint = self._stain if i == 0 else self._decoy
                paint(img[box], f, i - 1, pan[box], tilt[box], fp=fp)
        sky = np.clip(0.5 + (tilt - _SKYLINE - 0.5 * lift) / fp, 0, 1).astype(np.float32)
        img = img * (1 - sky[..., None]) + np.float32((235, 200, 150)) * sky[..., None]
        return np.clip(img, 0, 255).astype(np.uint8)

    def _grain(self, pan: np.ndarray, tilt: np.ndarray, fp: float) -> np.ndarray:
        """Fractal noise: each octave is the tile, rotated, scaled and shifted, sampled at
        view-local float32 coordinates (the view's centre carries the large part exactly)."""
        out = np.zeros(pan.shape, np.float32)
        p0, t0 = float(pan.flat[pan.size // 2]), float(tilt.flat[tilt.size // 2])
        dp, dt = (pan - p0).astype(np.float32), (tilt - t0).astype(np.float32)
        for wave, amp, rot, off in self._octaves:
            gain = amp * _attenuation(wave, fp)
            if gain < 3.6e-4:  # under a twentieth of a grey level on rock of ~140
                continue
            c, s = math.cos(rot), math.sin(rot)
            k = _TEXELS / wave
            u0 = ((p0 * c - t0 * s) * k + off[0]) % _TILE
            v0 = ((p0 * s + t0 * c) * k + off[1]) % _TILE
            u = _wrap(cv2.addWeighted(dp, c * k, dt, -s * k, u0))
            v = _wrap(cv2.addWeighted(dp, s * k, dt, c * k, v0))
            layer = cv2.remap(self._tile, u, v, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
            cv2.scaleAdd(layer, gain, out, dst=out)
        return out

    def _decoy(self, img, f: Feature, i: int, pan, tilt, *, fp: float) -> None:
        dx, dy = pan - f.pan, tilt - f.tilt
        if f.kind == "ledge_shadow":  # a long dark lens along the beds, lit by the sky alone
            minor = f.radius * self._shadow_height[i]
            cover = _cover(np.hypot(dx * minor / f.radius, dy), minor, fp)[..., None]
            img *= 1.0 - cover * (1.0 - SKY_SHADE)
        elif f.kind == "nodules":  # grey concretions, each 0.03 deg
            for nx, ny in self._nodules:
                cover = _cover(np.hypot(dx - nx * f.radius, dy - ny * f.radius), 0.015, fp)
                img += (cover[..., None] * (np.float32((150, 150, 150)) - img)) * 0.8
        else:  # a network of thin white veins (0.004 deg wide) within a disc
            inside = _cover(np.hypot(dx, dy), f.radius, fp)
            for theta in self._veins:
                d = np.abs(dx * math.sin(theta) - dy * math.cos(theta) + 0.2 * math.sin(theta * 7))
                cover = _cover(d, 0.002, fp) * inside
                img += cover[..., None] * (np.float32((240, 242, 244)) - img)

    def _stain(self, img, f: Feature, _i: int, pan, tilt, *, fp: float) -> None:
        """Wet rock: darker and more saturated; a bluish shadowed core; a white rim."""
        angle = np.arctan2(tilt - f.tilt, pan - f.pan)
        wobble = 1.0 + 0.1 * np.cos(3 * angle + self._seed) + 0.06 * np.cos(5 * angle)
        r = np.hypot(pan - f.pan, tilt - f.tilt) / wobble
        wet = _cover(r, f.radius, fp)[..., None]
        grey = img.mean(axis=2, keepdims=True)
        img += wet * ((grey + (img - grey) * 1.6) * 0.55 - img)
        rim = _cover(np.abs(r - f.radius), 0.015 * f.radius, fp)[..., None]
        img += rim * (np.float32((236, 240, 244)) - img)
        assert f.close is not None
        cx, cy, cr = f.close
        core = _cover(np.hypot(pan - cx, tilt - cy), cr, fp)[..., None]
        img += core * (np.float32((70, 38, 30)) - img)


def _wrap(x: np.ndarray) -> np.ndarray:
    """``x`` modulo the tile, in place: a fifth of ``np.mod``'s time on float32, the same
    values, and it is most of a frame's grain."""
    q = x * np.float32(1.0 / _TILE)
    np.floor(q, out=q)
    q *= np.float32(_TILE)
    x -= q
    return x


def _window(pan: np.ndarray, tilt: np.ndarray, f: Feature, fp: float):
    """The index box of the pixels a feature can touch, or None: features are painted only
    there (a frame sees one or two of them)."""
    reach = 1.3 * f.radius + fp
    near = (np.abs(pan - f.pan) <= reach) & (np.abs(tilt - f.tilt) <= reach)
    rows, cols = np.flatnonzero(near.any(axis=1)), np.flatnonzero(near.any(axis=0))
    if rows.size == 0:
        return None
    return slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1)


def _attenuation(wavelength: float, footprint: float) -> float:
    """How much of a sine of this wavelength survives a Gaussian pixel (sigma = fp / 2)."""
    sigma = footprint / 2.0
    return math.exp(-2.0 * (math.pi * sigma / wavelength) ** 2)


def _cover(x: np.ndarray, half: float, footprint: float) -> np.ndarray:
    """Coverage of a pixel ``footprint`` wide, ``x`` (>= 0) from the centre line or point of
    a shape ``half`` wide each way: 1 deep inside, a one-pixel ramp at the edge, and for a
    shape narrower than a pixel its share of the pixel (a sub-pixel vein fades, as on a
    sensor, instead of flickering)."""
    hi = np.minimum(x + footprint / 2.0, half)
    lo = np.maximum(x - footprint / 2.0, -half)
    return (np.clip(hi - lo, 0.0, footprint) / footprint).astype(np.float32)
