"""Benchmark regimes: labelled outcrop scenes beyond the tiny-target case, deterministic by seed.

``outcrop_scene`` plants 4-8 px targets, and a detector tuned on it alone learns that
"interesting" means "tiny". Each regime here asks a different question of the same
detectors, and ``bench/quality.py`` reports them separately:

* ``tiny``: ``outcrop_scene`` itself, unchanged;
* ``seed``: the seed papers' own case (McGuire et al. 2004-05, Figs. 4, 5, 7), a 108x192
  quasi-mosaic of a pale gypsum/clay cliff with two dark wet stains (1-2 % of the image
  each) and one ledge shadow;
* ``large``: one or two targets of 5-15 % of the image (a lichen patch, a red-bed lens, a
  white gypsum lens, a dark wet patch): rare, but not small;
* ``veins``: one or two veins or cracks 1.5-3 px wide and 40-120 px long in dark rock,
  among 2-4 ledge shadows: rare and thin, where the shadows are long and thick;
* ``empty``: beds and 2-4 ledge shadows, no target: where does the best point go then?

``camera_effects.through_camera`` shows any of them as an ordinary camera delivers a frame
(vignetting, a light gradient, slight defocus, JPEG), for ``bench/quality.py --camera``.

Every scene keeps the quasi-mosaic look (butted tiles with their own exposure, sensor
noise) and fills ``targets``, ``target_labels`` and ``shadow_mask`` (the decoys). Targets are
placed first and decoys kept clear of them, so a point is never on both. Painting and blob
shapes come from ``scene``; beds from a chosen palette (returning their texture), ledge
shadows and the quasi-mosaic finish, which every regime shares, from ``draw``.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

from .draw import beds, clearance, darken, finish, grow, label_image, ledge_shadows
from .scene import _ROCKS, Scene, Target, _blob, _noise, _paint_target, outcrop_scene

__all__ = [
    "DESCRIPTIONS",
    "LARGE_KINDS",
    "REGIMES",
    "VEIN_KINDS",
    "empty_scene",
    "large_scene",
    "seed_cliff",
    "vein_scene",
]

LARGE_KINDS = ("lichen", "red_lens", "gypsum_lens", "wet_patch")
VEIN_KINDS = ("white_vein", "pale_vein", "dark_crack")

# BGR. Pale, low-saturation beds of the seed's gypsum/clay cliff (Rivas Vaciamadrid):
# white gypsum, light and darker buff, grey and greenish-grey clay, pale grey marl.
_PALE_ROCKS = np.array(
    [
        (204, 210, 216),
        (176, 190, 204),
        (150, 168, 184),
        (148, 152, 156),
        (148, 156, 152),
        (180, 182, 184),
    ],
    np.float32,
)
# BGR. Dark host rock for veins: red sandstone and shale from ``_ROCKS``, dark red mudstone,
# dark grey siltstone, brown sandstone.
_DARK_ROCKS = np.array(
    [tuple(_ROCKS[1]), tuple(_ROCKS[4]), (52, 62, 118), (66, 68, 72), (56, 80, 112)],
    np.float32,
)
# Beds of ``_ROCKS`` a large target must not share its colour with, or it would not be rare:
# no red sandstone around a red-bed lens, no gypsum or pale buff around a gypsum lens.
_LARGE_EXCLUDES = {"red_lens": (1,), "gypsum_lens": (3, 6)}


def seed_cliff(seed: int, shadow: bool = True) -> Scene:
    """The seed papers' scene: a pale layered gypsum/clay cliff with two dark wet stains.

    A 108x192 quasi-mosaic of 3x4 butted 36x48 tiles (the seed's wearable mosaic size):
    low-saturation buff, white and grey beds with strong lamination and grain, each tile
    with its own exposure, sensor noise. Two wet stains, irregular blobs of 1-2 % of the
    image each, darker and a bit more saturated than their host (``wet_stain``); one ledge
    shadow, an elongated dark ellipse, is the decoy the seed papers found their maps drawn
    to; ``shadow=False`` leaves it out (the same cliff and stains otherwise), which is the
    case the seed's figures show. Deterministic by ``seed``.

    Examples
    --------
    >>> s = seed_cliff(0)
    >>> s.image.shape, [t.kind for t in s.targets], bool(s.shadow_mask.any())
    ((108, 192, 3), ['wet_stain', 'wet_stain'], True)
    """
    rng = np.random.default_rng([seed, 1])
    shape = rows, cols = (108, 192)
    n_beds = int(rng.integers(6, 10))
    img, _ = beds(rng, shape, _PALE_ROCKS, n_beds, lamination=0.05, jitter=0.03)
    gap = clearance(shape)
    masks: list[np.ndarray] = []
    targets: list[Target] = []
    for _ in range(200):
        if len(targets) == 2:
            break
        r = float(np.sqrt(rng.uniform(0.012, 0.018) * rows * cols / np.pi))
        cx, cy = rng.uniform(1.4 * r, cols - 1.4 * r), rng.uniform(1.4 * r, rows - 1.4 * r)
        m = _blob(rng, shape, cx, cy, r)
        if not 0.01 <= m.mean() <= 0.02 or any((m & grow(o, gap)).any() for o in masks):
            continue
        masks.append(m)
        targets.append(Target("wet_stain", float(cx), float(cy), r))
    avoid = grow(np.logical_or.reduce(masks), gap)
    ledge = ledge_shadows(rng, shape, 1, 0, avoid, length=(40.0, 90.0))
    for m in masks:
        _paint_target(rng, img, "wet_stain", m)
    factor = rng.uniform(0.8, 1.1)  # drawn either way, so the cliff does not change
    if not shadow:
        ledge[:] = False
    darken(img, ledge, factor)
    out = finish(rng, img, exposure=0.06)
    return Scene(out, tuple(targets), label_image(shape, masks), ledge, seed)


def _lens(
    rng: np.random.Generator,
    shape: tuple[int, int],
    centre: tuple[float, float],
    *,
    half_length: float,
    half_thickness: float,
    angle: float,
) -> np.ndarray:
    """A lens along the bedding: thickest in the middle, pinching out at both ends, with a
    wobbly rim. Its area is about 8/3 x half_length x half_thickness."""
    rows, cols = shape
    yy, xx = np.mgrid[0:rows, 0:cols].astype(np.float32)
    dx, dy = xx - centre[0], yy - centre[1]
    u = dx * np.cos(angle) + dy * np.sin(angle)
    v = -dx * np.sin(angle) + dy * np.cos(angle)
    t = np.clip(u / half_length, -1.0, 1.0)
    wobble = 1.0 + 0.12 * np.sin(3 * np.pi * t + rng.uniform(0, 2 * np.pi))
    return (np.abs(u) < half_length) & (np.abs(v) <= half_thickness * (1 - t * t) * wobble)


def _paint_large(
    rng: np.random.Generator, img: np.ndarray, kind: str, mask: np.ndarray, texture: np.ndarray
) -> None:
    """Paint a large target with grain, as a bed is painted: a flat patch of this size
    would be rare for its smoothness alone."""
    if kind == "wet_patch":  # wet rock keeps its host's texture: reuse the small stain
        _paint_target(rng, img, "wet_stain", mask)
        return
    t = texture[mask][:, None]
    if kind == "lichen":  # grey-green to yellow-green, patchy
        colour = np.array([rng.uniform(60, 120), rng.uniform(140, 170), rng.uniform(110, 150)])
        patches = _noise(rng, mask.shape, (1.0, 3.0))[mask][:, None]
        img[mask] = colour * (1.0 + 0.08 * t + 0.1 * patches)
    elif kind == "red_lens":  # rust-red sandstone, more saturated than any bed
        colour = np.array([rng.uniform(35, 50), rng.uniform(45, 65), rng.uniform(160, 185)])
        img[mask] = colour * (1.0 + 0.07 * t)
    else:  # gypsum_lens: white
        colour = rng.uniform(212, 230) + rng.uniform(-4, 4, 3)
        img[mask] = colour * (1.0 + 0.04 * t)


def large_scene(seed: int) -> Scene:
    """One or two large targets, 5-15 % of the image each, on a 216x288 outcrop.

    Kinds: a lichen patch, a red-bed lens, a white gypsum lens, a dark wet patch (see
    ``LARGE_KINDS``). Lenses lie along the bedding; patches are irregular blobs. No bed
    shares a lens's colour, so every target is rare in colour, only not small. 2-4 ledge
    shadows are the decoys, a sky strip half the time. Deterministic by ``seed``.

    Examples
    --------
    >>> s = large_scene(0)
    >>> s.image.shape, 1 <= len(s.targets) <= 2
    ((216, 288, 3), True)
    """
    rng = np.random.default_rng([seed, 2])
    shape = rows, cols = (216, 288)
    count = int(rng.integers(1, 3))
    kinds = [LARGE_KINDS[int(i)] for i in rng.choice(len(LARGE_KINDS), count, replace=False)]
    excluded = {i for k in kinds for i in _LARGE_EXCLUDES.get(k, ())}
    palette = _ROCKS[[i for i in range(len(_ROCKS)) if i not in excluded]]
    sky = int(rng.uniform(0.08, 0.22) * rows) if rng.random() < 0.5 else 0
    img, texture = beds(rng, shape, palette, int(rng.integers(4, 8)), sky=sky)
    gap = clearance(shape)
    masks: list[np.ndarray] = []
    targets: list[Target] = []
    for _ in range(300):
        if len(masks) == count:
            break
        kind = kinds[len(masks)]
        area = rng.uniform(0.06, 0.13 if count == 1 else 0.09) * rows * cols
        cx, cy = rng.uniform(0, cols), rng.uniform(sky, rows)
        if kind.endswith("_lens"):
            aspect = rng.uniform(2.5, 4.0)
            b = float(np.sqrt(3 * area / (8 * aspect)))
            tilt = rng.uniform(-0.15, 0.15)
            m = _lens(rng, shape, (cx, cy), half_length=aspect * b, half_thickness=b, angle=tilt)
            reach = aspect * b
        else:
            reach = float(np.sqrt(area / np.pi))
            m = _blob(rng, shape, cx, cy, reach)
        ys, xs = np.nonzero(m)
        if not 0.05 <= m.mean() <= 0.15 or ys.min() <= sky or ys.max() >= rows - 1:
            continue
        if xs.min() == 0 or xs.max() == cols - 1:
            continue
        if any((m & grow(o, gap)).any() for o in masks):
            continue
        masks.append(m)
        targets.append(Target(kind, float(xs.mean()), float(ys.mean()), reach))
    avoid = grow(np.logical_or.reduce(masks), gap)
    shadow = ledge_shadows(rng, shape, int(rng.integers(2, 5)), sky, avoid)
    for kind, m in zip(kinds[: len(masks)], masks, strict=True):
        _paint_large(rng, img, kind, m, texture)
    darken(img, shadow, rng.uniform(0.8, 1.1))
    out = finish(rng, img)
    return Scene(out, tuple(targets), label_image(shape, masks), shadow, seed)


def _curve(
    rng: np.random.Generator, shape: tuple[int, int], length: float, margin: float
) -> np.ndarray | None:
    """Centre line of a vein: points 1 px apart, heading anywhere (veins cut the bedding),
    bending gently with a little wiggle. None if it would leave the image."""
    rows, cols = shape
    steps = int(length)
    heading = rng.uniform(0, np.pi) + np.cumsum(
        np.full(steps, rng.uniform(-1, 1) / 90.0)
        + 0.02 * np.sin(np.arange(steps) / rng.uniform(6, 15) + rng.uniform(0, 6.3))
    )
    start = np.array([rng.uniform(0, cols), rng.uniform(0, rows)])
    pts = start + np.cumsum(np.stack([np.cos(heading), np.sin(heading)], axis=1), axis=0)
    pts = np.vstack([start, pts])
    inside = (pts >= margin).all() and (pts[:, 0] <= cols - 1 - margin).all()
    return pts if inside and (pts[:, 1] <= rows - 1 - margin).all() else None


def _stroke(shape: tuple[int, int], pts: np.ndarray, widths: np.ndarray, ss: int = 8) -> np.ndarray:
    """Area coverage (0..1) of a stroke of varying width along ``pts`` (x, y pixel centres),
    drawn ``ss`` times finer and averaged back: a 1.5 px vein must cover pixels partly, as a
    lens would image it, not snap to 1 or 2 whole pixels."""
    rows, cols = shape
    canvas = np.zeros((rows * ss, cols * ss), np.uint8)
    shift = 4
    fine = np.round((pts * ss + (ss - 1) / 2.0) * (1 << shift)).astype(np.int64)
    for i in range(len(fine) - 1):
        a, b = (int(v) for v in fine[i]), (int(v) for v in fine[i + 1])
        thick = max(1, round(widths[i] * ss))
        cv2.line(canvas, tuple(a), tuple(b), 255, thick, cv2.LINE_8, shift)
    return cv2.resize(canvas, (cols, rows), interpolation=cv2.INTER_AREA).astype(np.float32) / 255


def vein_scene(seed: int) -> Scene:
    """One or two thin veins or cracks in dark rock, among 2-4 ledge shadows (the decoys).

    Each is 1.5-3 px wide and 40-120 px long, gently curved: a white calcite/gypsum vein,
    a pale cream vein (both rare in colour in red or dark rock), or a dark mineral-filled
    crack, darker than the shadows but thin where they are thick. Labels are the pixels
    the stroke covers by half or more; ``Target.radius`` is half the vein's length.
    216x288, no sky. Deterministic by ``seed``.

    Examples
    --------
    >>> s = vein_scene(0)
    >>> s.image.shape, all(t.kind in VEIN_KINDS for t in s.targets)
    ((216, 288, 3), True)
    """
    rng = np.random.default_rng([seed, 3])
    shape = (216, 288)
    img, _ = beds(rng, shape, _DARK_ROCKS, int(rng.integers(3, 7)))
    count = int(rng.integers(1, 3))
    gap = clearance(shape)
    masks: list[np.ndarray] = []
    covers: list[np.ndarray] = []
    targets: list[Target] = []
    for _ in range(300):
        if len(masks) == count:
            break
        length = rng.uniform(40, 120)
        pts = _curve(rng, shape, length, margin=4.0)
        if pts is None:
            continue
        width = rng.uniform(1.5, 3.0)
        along = np.arange(len(pts)) / rng.uniform(8, 20) + rng.uniform(0, 6.3)
        widths = np.clip(width * (1 + 0.15 * np.sin(along)), 1.5, 3.0)
        cover = _stroke(shape, pts, widths)
        m = cover >= 0.5
        if any((m & grow(o, gap)).any() for o in masks):
            continue
        kind = VEIN_KINDS[int(rng.choice(len(VEIN_KINDS), p=[0.5, 0.3, 0.2]))]
        mid = pts[len(pts) // 2]
        masks.append(m)
        covers.append(cover)
        targets.append(Target(kind, float(mid[0]), float(mid[1]), float(length / 2)))
    avoid = grow(np.logical_or.reduce(masks), gap)
    shadow = ledge_shadows(rng, shape, int(rng.integers(2, 5)), 0, avoid)
    for t, cover in zip(targets, covers, strict=True):
        alpha = cover[..., None]
        if t.kind == "white_vein":
            paint = rng.uniform(225, 245) + 6 * rng.standard_normal(shape)[..., None]
        elif t.kind == "pale_vein":
            paint = np.array([rng.uniform(165, 185), rng.uniform(195, 210), rng.uniform(210, 225)])
        else:  # dark_crack
            paint = img * rng.uniform(0.25, 0.35)
        img[:] = img * (1 - alpha) + paint * alpha
    darken(img, shadow, rng.uniform(0.8, 1.1))
    out = finish(rng, img)
    return Scene(out, tuple(targets), label_image(shape, masks), shadow, seed)


def empty_scene(seed: int) -> Scene:
    """No target at all: ``outcrop_scene(seed)``'s beds, sky and 2-4 ledge shadows alone.

    Scene i is ``tiny`` scene i with its targets left out (same beds and shadows; tile
    exposures and noise differ), so the two regimes form a paired control: the best point
    can only land on rock, sky or a decoy.

    Examples
    --------
    >>> s = empty_scene(3)
    >>> s.targets, int(s.target_labels.max()), bool(s.shadow_mask.any())
    ((), 0, True)
    """
    return outcrop_scene(seed, n_targets=0)


REGIMES: dict[str, Callable[[int], Scene]] = {
    "tiny": outcrop_scene,
    "seed": seed_cliff,
    "large": large_scene,
    "veins": vein_scene,
    "empty": empty_scene,
}
"""Scene generator of each regime, by name, in report order."""

DESCRIPTIONS: dict[str, str] = {
    "tiny": "1-3 targets of 4-8 px radius (outcrop_scene)",
    "seed": "seed paper's gypsum cliff: 2 dark wet stains of 1-2 % each, 1 ledge shadow",
    "large": "1-2 targets of 5-15 % of the image (lichen, red/gypsum lens, wet patch)",
    "veins": "1-2 veins or cracks 1.5-3 px wide, 40-120 px long, among ledge shadows",
    "empty": "no target: beds, sky and 2-4 ledge shadows only",
}
