"""No-data fill benchmark: the real images as mosaic tiles and registered panoramas.

The held-out real images include mosaic tiles with a black no-data fill, which the dev half
lacks; here each real image (``bench.real``'s data and scoring) is framed two ways, its mask
with it, and scored as ``bench.real`` scores it:

* ``tile``: the image shifted inside its frame by 20-40 % across and 0-25 % down (a tile
  at a mosaic's corner), black beyond;
* ``turned``: the image turned 6-15 degrees about its centre (a registered panorama), black
  in the corners.

Each variant is stored as a JPEG at quality 90 (the AI4Mars frames are JPEGs, so their fill
is near black, not exactly 0) and decoded. Besides top1 / any3 / repeat@1 it counts
``on fill``: the share of images whose best point lies on the fill or within the hit radius
of it (a point there is on the fill's edge, not on anything in the image). Offsets and angles
come from crc32 of the image's name, so every method and every run sees the same frames.

Usage: ``python -m bench.nodata [--data DIR] [--sets a,b] [--limit N] [--methods a,b]
[--jpeg Q]`` (``--jpeg``: the repeat looks through a JPEG at Q, as in ``bench.real``).
"""

from __future__ import annotations

import argparse
import sys
import zlib
from pathlib import Path

import cv2
import numpy as np

from bench.real import _choose, default_data_dir, list_sets, read_manifest
from bench.real_score import REPEAT_SHARE, diagonal, hits, looks, near_mask, score
from bench.stats import repeats
from cyborg.daemon.sim.camera_effects import jpeg_round_trip
from cyborg.daemon.vision.imageio import read_image

VARIANTS = ("tile", "turned")
DEFAULT_METHODS = ("default", "paper", "spectral-residual", "colour-rarity", "rx-anomaly")


def framed(
    image: np.ndarray, mask: np.ndarray, variant: str, seed: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(image, target mask, fill mask) of one variant; the image as a JPEG at quality 90."""
    rng = np.random.default_rng([seed, 7])
    rows, cols = image.shape[:2]
    if variant == "tile":
        dx = round(cols * rng.uniform(0.2, 0.4)) * (1 if rng.random() < 0.5 else -1)
        dy = round(rows * rng.uniform(0.0, 0.25)) * (1 if rng.random() < 0.5 else -1)
        warp = np.float32([[1, 0, dx], [0, 1, dy]])
    else:
        angle = rng.uniform(6.0, 15.0) * (1 if rng.random() < 0.5 else -1)
        warp = cv2.getRotationMatrix2D(((cols - 1) / 2, (rows - 1) / 2), angle, 1.0)
    size = (cols, rows)
    out = cv2.warpAffine(image, warp, size, flags=cv2.INTER_LINEAR, borderValue=0)
    target = cv2.warpAffine(mask, warp, size, flags=cv2.INTER_NEAREST, borderValue=0)
    inside = cv2.warpAffine(np.full(mask.shape, 255, np.uint8), warp, size, borderValue=0)
    return jpeg_round_trip(out, 90), target, inside == 0


def run(
    data: Path, sets: list[str], limit: int | None, names: list[str], jpeg: int | None
) -> dict[str, dict[str, dict[str, float]]]:
    """Per set and variant: method -> rates (top1, any3, repeat1, on_fill)."""
    table = _choose(names)
    out: dict[str, dict[str, dict[str, float]]] = {}
    for set_name in sets:
        folder = data / set_name
        for variant in VARIANTS:
            tally: dict[str, list[dict[str, float]]] = {m: [] for m in table}
            for name, _tag in read_manifest(folder)[:limit]:
                seed = zlib.crc32(f"{set_name}/{name}".encode())
                image = read_image(folder / "images" / name)
                mask = read_image(folder / "masks" / name)
                mask = mask.max(axis=2) if mask.ndim == 3 else mask
                image, target, fill = framed(image, mask, variant, seed)
                near, on_fill = near_mask(target), near_mask(fill)
                noisy = looks(image, seed, jpeg)
                tolerance = REPEAT_SHARE * diagonal(image.shape)
                for m, method in table.items():
                    points = method(image, np.random.default_rng([seed, 0]))
                    again = [
                        method(v, np.random.default_rng([seed, 1 + k])) for k, v in enumerate(noisy)
                    ]
                    rates = score(hits(near, points))
                    rates["repeat1"] = float(repeats(*again, tolerance))
                    rates["on_fill"] = float(bool(points) and hits(on_fill, points[:1])[0])
                    tally[m].append(rates)
            out[f"{set_name}/{variant}"] = {
                m: {k: float(np.mean([r[k] for r in rows])) for k in rows[0]} | {"n": len(rows)}
                for m, rows in tally.items()
                if rows
            }
            print(f"nodata: {set_name}/{variant} done", file=sys.stderr, flush=True)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=None)
    ap.add_argument("--sets", default="ai4mars,marsdata")
    ap.add_argument("--limit", type=int, default=None)
    ap.add_argument("--methods", default=",".join(DEFAULT_METHODS))
    ap.add_argument("--jpeg", type=int, default=None, metavar="Q")
    args = ap.parse_args(argv)
    data = args.data or default_data_dir()
    if not data.is_dir() or not list_sets(data):
        print(f"nodata: data folder {data} is absent (no sets); nothing to score")
        return 0
    sets = [s for s in args.sets.split(",") if s]
    names = [m for m in args.methods.split(",") if m]
    results = run(data, sets, args.limit, names, args.jpeg)
    for group, rates in results.items():
        n = next(iter(rates.values()))["n"]
        print(f"\n{group} ({n} images)")
        print(f"  {'method':18s} {'top1':>7s} {'any3':>7s} {'repeat@1':>9s} {'on fill':>8s}")
        for m, r in rates.items():
            cells = " ".join(f"{100 * r[k]:6.1f}%" for k in ("top1", "any3"))
            print(f"  {m:18s} {cells} {100 * r['repeat1']:8.1f}% {100 * r['on_fill']:7.1f}%")
    return 0


if __name__ == "__main__":
    sys.exit(main())
