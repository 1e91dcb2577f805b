"""Procedural outcrop scenes with labelled planted targets, deterministic by seed.

A scene is a quasi-mosaic of a layered sedimentary cliff, as the rig would build it: rock
beds with undulating contacts, lamination and grain texture, an optional sky strip, 3-D
ledge shadows (the decoys the seed papers complain about), per-tile exposure differences
(the tiles are butted, not blended) and sensor noise. Planted targets are small uncommon
features a geologist would walk to: a dark wet stain, a green plant, a white vein knot, a
red spot. Their masks are the ground truth for ``bench/quality.py``; the same generator
feeds the demo and the simulated camera.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["SKY_SHADE", "TARGET_KINDS", "Scene", "Target", "outcrop_scene"]

SKY_SHADE = np.array([0.55, 0.45, 0.40], np.float32)
"""B, G, R kept by rock in a ledge's shade: lit by the sky alone, darker and bluer than in
the sun (``daemon.vision.shadow`` reads shade by this direction, not these numbers)."""

TARGET_KINDS = ("wet_stain", "plant", "vein_knot", "red_spot")

# BGR colours of common beds: buff and red sandstone, grey clay, gypsum, shale, ochre marl.
_ROCKS = np.array(
    [
        (118, 158, 190),
        (70, 92, 158),
        (138, 140, 142),
        (196, 202, 208),
        (88, 92, 98),
        (72, 128, 172),
        (150, 168, 180),
    ],
    np.float32,
)


@dataclass(frozen=True)
class Target:
    """A planted feature: its kind, centre (x = column, y = row) and size in pixels."""

    kind: str
    x: float
    y: float
    radius: float


@dataclass(frozen=True)
class Scene:
    image: np.ndarray
    """(M, N, 3) uint8 BGR."""
    targets: tuple[Target, ...]
    target_labels: np.ndarray
    """(M, N) uint8: 0 = background, i = pixel of ``targets[i - 1]``."""
    shadow_mask: np.ndarray
    """(M, N) bool: where a decoy shadow darkens the rock."""
    seed: int


def _noise(
    rng: np.random.Generator, shape: tuple[int, int], scales: tuple[float, ...]
) -> np.ndarray:
    """Zero-mean, unit-ish fractal noise: blurred white noise summed over scales."""
    out = np.zeros(shape, np.float32)
    for i, s in enumerate(scales):
        layer = rng.standard_normal(shape).astype(np.float32)
        if s > 0.5:
            layer = cv2.GaussianBlur(layer, (0, 0), s)
            layer /= max(float(layer.std()), 1e-6)
        out += layer / (i + 1)
    return out / max(float(out.std()), 1e-6)


def _blob(
    rng: np.random.Generator, shape: tuple[int, int], cx: float, cy: float, r: float
) -> np.ndarray:
    """An irregular filled blob (a circle with a wobbly rim) as a bool mask, evaluated
    only in the box its rim can reach (a large scene has millions of pixels)."""
    rows, cols = shape
    terms = [(k, rng.standard_normal(), rng.uniform(0, 2 * np.pi)) for k in (2, 3, 5)]
    reach = r * (1.0 + 0.12 * sum(abs(amp) for _, amp, _ in terms)) + 1.0
    top, left = max(0, int(cy - reach)), max(0, int(cx - reach))
    bottom, right = min(rows, int(cy + reach) + 2), min(cols, int(cx + reach) + 2)
    yy, xx = np.mgrid[top:bottom, left:right].astype(np.float32)
    ang = np.arctan2(yy - cy, xx - cx)
    wobble = np.ones_like(ang)
    for k, amp, phase in terms:
        wobble += 0.12 * amp * np.cos(k * ang + phase)
    mask = np.zeros(shape, bool)
    mask[top:bottom, left:right] = np.hypot(xx - cx, yy - cy) <= r * wobble
    return mask


def _paint_target(rng: np.random.Generator, img: np.ndarray, kind: str, mask: np.ndarray) -> None:
    n = int(mask.sum())
    if kind == "wet_stain":  # wet rock: darker and more saturated than its host
        host = img[mask]
        grey = host.mean(axis=1, keepdims=True)
        img[mask] = (grey + (host - grey) * 1.6) * rng.uniform(0.45, 0.6)
    elif kind == "plant":
        base = np.array([rng.uniform(30, 60), rng.uniform(120, 160), rng.uniform(50, 90)])
        img[mask] = base * (1 + 0.12 * rng.standard_normal((n, 1)))
    elif kind == "vein_knot":
        base = rng.uniform(228, 245)
        img[mask] = base + 6 * rng.standard_normal((n, 1))
    else:  # red_spot: rust red, more saturated than any bed
        base = np.array([rng.uniform(20, 40), rng.uniform(30, 50), rng.uniform(170, 200)])
        img[mask] = base * (1 + 0.08 * rng.standard_normal((n, 1)))


def outcrop_scene(
    seed: int,
    shape: tuple[int, int] = (216, 288),
    n_targets: int | None = None,
    tiles: tuple[int, int] = (3, 4),
    shadows: bool = True,
) -> Scene:
    """Render one labelled outcrop quasi-mosaic.

    Parameters
    ----------
    seed : int
        Everything is drawn from ``numpy.random.default_rng(seed)``.
    shape : (M, N)
        Mosaic size in pixels; (216, 288) is a 3x4 mosaic of 288x384 frames reduced 4x.
    n_targets : int, optional
        1..3 when not given.
    tiles : (rows, cols)
        Tile grid whose exposures differ slightly, as in a butted quasi-mosaic.
    shadows : bool
        Add 2..4 ledge shadows as decoys.

    Returns
    -------
    Scene

    Examples
    --------
    >>> a, b = outcrop_scene(3), outcrop_scene(3)
    >>> a.image.shape, bool((a.image == b.image).all()), len(a.targets) >= 1
    ((216, 288, 3), True, True)
    """
    rng = np.random.default_rng(seed)
    rows, cols = shape
    scale = min(rows / 216.0, cols / 288.0)
    img = np.zeros((rows, cols, 3), np.float32)
    xs = np.arange(cols, dtype=np.float32)

    # Beds: contacts undulate and dip; each bed has its own colour, lamination and grain.
    sky = int(rng.uniform(0.08, 0.22) * rows) if rng.random() < 0.5 else 0
    n_beds = int(rng.integers(4, 8))
    palette = _ROCKS[rng.choice(len(_ROCKS), n_beds, replace=True)]
    cuts = np.sort(rng.uniform(sky, rows, n_beds - 1))
    dip = rng.uniform(-0.08, 0.08)
    yy = np.arange(rows, dtype=np.float32)[:, None]
    bed = np.zeros((rows, cols), np.int32)
    for c in cuts:
        wave = (
            c
            + dip * (xs - cols / 2)
            + rng.uniform(2, 6)
            * scale
            * np.sin(2 * np.pi * xs / rng.uniform(60, 200) / scale + rng.uniform(0, 6.3))
        )
        bed += (yy > wave[None, :]).astype(np.int32)
    grain = _noise(rng, shape, (0.0, 1.5 * scale, 6.0 * scale))
    lamination = np.sin(yy * rng.uniform(0.6, 1.4) / scale + 0.3 * grain)
    for k in range(n_beds):
        m = bed == k
        colour = palette[k] * rng.uniform(0.9, 1.1, 3)
        texture = 1.0 + 0.07 * grain[m] + 0.03 * lamination[m]
        img[m] = colour[None, :] * texture[:, None]
    if sky:
        top = np.linspace(1.0, 0.8, sky, dtype=np.float32)[:, None, None]
        img[:sky] = np.array([225, 190, 150], np.float32) * top

    # Decoys: shadows under ledges, dark and slightly blue (lit by the sky only).
    shadow = np.zeros(shape, bool)
    if shadows:
        for _ in range(int(rng.integers(2, 5))):
            cy = rng.uniform(sky + 10 * scale, rows - 5 * scale)
            cx = rng.uniform(0, cols)
            axes = (int(rng.uniform(25, 70) * scale), int(rng.uniform(4, 10) * scale))
            m = np.zeros(shape, np.uint8)
            cv2.ellipse(m, (int(cx), int(cy)), axes, rng.uniform(-10, 10), 0, 360, 1, -1)
            shadow |= m.astype(bool)
        img[shadow] *= SKY_SHADE * rng.uniform(0.8, 1.1)

    # Planted targets, kept apart from each other and from the sky.
    count = int(rng.integers(1, 4)) if n_targets is None else n_targets
    labels = np.zeros(shape, np.uint8)
    targets: list[Target] = []
    for _ in range(100):
        if len(targets) == count:
            break
        r = rng.uniform(4.0, 8.0) * scale
        cx = rng.uniform(2 * r, cols - 2 * r)
        cy = rng.uniform(max(sky + 2 * r, 2 * r), rows - 2 * r)
        if any(np.hypot(cx - t.x, cy - t.y) < 6 * r for t in targets):
            continue
        kind = TARGET_KINDS[int(rng.integers(len(TARGET_KINDS)))]
        m = _blob(rng, shape, cx, cy, r)
        _paint_target(rng, img, kind, m)
        labels[m & (labels == 0)] = len(targets) + 1
        targets.append(Target(kind, float(cx), float(cy), float(r)))

    # Quasi-mosaic: each butted tile has its own exposure; then sensor noise.
    trows, tcols = tiles
    for i in range(trows):
        for j in range(tcols):
            r0, r1 = i * rows // trows, (i + 1) * rows // trows
            c0, c1 = j * cols // tcols, (j + 1) * cols // tcols
            img[r0:r1, c0:c1] *= rng.uniform(0.95, 1.05)
    img += rng.normal(0.0, 3.0, img.shape).astype(np.float32)
    out = np.clip(img, 0, 255).astype(np.uint8)
    return Scene(out, tuple(targets), labels, shadow, seed)
