"""Offline analysis: run the science core on image files and write every product to disk."""

from __future__ import annotations

import json
import logging
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

import cv2
import numpy as np

from .imageio import ImageError, as_bgr8, read_image, write_atomic, write_jpeg, write_png
from .vision import render
from .vision.explain import PLANE_NAMES, describe
from .vision.interest import InterestPoint
from .vision.params import VisionParams, profile
from .vision.pipeline import Analysis, analyze
from .vision.uncommon import uncommon_map

_LOGGER = logging.getLogger(__name__)

__all__ = [
    "AnalyzeOptions",
    "analyse_into",
    "analyze_files",
    "analyze_image",
    "input_points",
    "write_products",
]


@dataclass(frozen=True)
class AnalyzeOptions:
    out: Path
    profile: str
    params: VisionParams
    downsample: float | None = None
    """None: the profile's working size (``max_pixels``)."""
    json_lines: bool = False


def working_reduction(shape: tuple[int, ...], params: VisionParams) -> float:
    """How much to reduce an image of this shape before analysis: 1 up to ``max_pixels``.

    >>> from daemon.vision.params import DEFAULT
    >>> working_reduction((3000, 4000), DEFAULT) > 3.0, working_reduction((300, 400), DEFAULT)
    (True, 1.0)
    """
    pixels = shape[0] * shape[1]
    if not params.max_pixels or pixels <= params.max_pixels:
        return 1.0
    return math.sqrt(pixels / params.max_pixels)


def analyze_image(
    image: np.ndarray,
    params: VisionParams,
    downsample: float | None = None,
    prior: np.ndarray | None = None,
) -> tuple[np.ndarray, Analysis]:
    """Normalise, reduce (as the seed did, 4-8x; by default to the profile's working size),
    analyse (with ``prior`` weights over the same ground, ``pipeline.analyze``); returns
    (bgr, analysis)."""
    bgr = as_bgr8(image)
    if downsample is None:
        downsample = working_reduction(bgr.shape, params)
    work = bgr
    if downsample != 1.0:
        rows, cols = bgr.shape[:2]
        size = (max(1, int(cols / downsample)), max(1, int(rows / downsample)))
        work = cv2.resize(bgr, size, interpolation=cv2.INTER_AREA)
    return bgr, analyze(work, params, prior)


def _to_input(value: float, scale: float) -> float:
    """Analysed-pixel coordinate -> input-pixel coordinate (pixel centres line up)."""
    return (value + 0.5) * scale - 0.5


def input_points(shape: tuple[int, ...], res: Analysis) -> list[InterestPoint]:
    """The analysis's points in the pixels of an input of this shape (it may have been
    reduced before analysis)."""
    arows, acols = res.hsi.i.shape
    sx, sy = shape[1] / acols, shape[0] / arows
    return [
        InterestPoint(p.rank, _to_input(p.x, sx), _to_input(p.y, sy), p.score, p.radius * sx)
        for p in res.points
    ]


def result_document(
    path: str, bgr: np.ndarray, res: Analysis, profile: str, products: dict[str, str]
) -> dict[str, Any]:
    """The ``result.json`` contents: points in input pixels, classes, parameters, timings."""
    rows, cols = bgr.shape[:2]
    arows, acols = res.hsi.i.shape
    found = input_points(bgr.shape, res)
    points = []
    for p, expl, line in zip(found, res.explanations, res.descriptions, strict=True):
        points.append(
            {
                "rank": p.rank,
                "x": round(p.x, 2),
                "y": round(p.y, 2),
                "radius": round(p.radius, 2),
                "score": round(p.score, 4),
                "description": line,
                "summary": describe(expl),
                "explanation": expl,
            }
        )
    classes = {
        name: [
            {"label": k, "value": seg.original_value(c.center), "radius": c.radius, "area": c.area}
            for k, c in enumerate(seg.classes, start=1)
        ]
        for name, seg in zip(PLANE_NAMES, res.segmentations, strict=True)
    }
    return {
        "image": path,
        "width": cols,
        "height": rows,
        "analysed": {"width": acols, "height": arows},
        "profile": profile,
        "params": res.params.to_dict(),
        "points": points,
        "classes": classes,
        "timing_ms": {k: round(v, 3) for k, v in res.timings_ms.items()},
        "products": products,
    }


def write_products(
    folder: Path, path: str, bgr: np.ndarray, res: Analysis, profile: str
) -> dict[str, Any]:
    """Write planes, segmentations, co-occurrence plots, maps, overlay and result.json."""
    params = res.params
    products: dict[str, str] = {}

    def put(name: str, image: np.ndarray) -> None:
        write_png(folder / name, image)
        products[name.removesuffix(".png")] = name

    for name, plane, seg in zip(PLANE_NAMES, res.hsi.planes, res.segmentations, strict=True):
        low = name.lower()
        put(f"plane_{low}.png", plane)
        put(f"segmentation_{low}.png", render.segmentation_image(seg))
        put(f"cooccurrence_{low}.png", render.cooccurrence_plot(seg))
        put(f"uncommon_{low}.png", render.grey_ramp(uncommon_map(seg, params), vmax=8.0))
    interest = np.maximum(res.interest.full(), 0.0)
    put("interest.png", render.grey_ramp(interest))
    scale = bgr.shape[1] / res.hsi.i.shape[1]
    if scale == 1.0:
        put("overlay.png", render.overlay(bgr, res.points))
    else:  # a big input: the overlay at the analysed size, and a JPEG at full size
        small = cv2.resize(bgr, res.hsi.i.shape[::-1], interpolation=cv2.INTER_AREA)
        put("overlay.png", render.overlay(small, res.points))
        write_jpeg(folder / "overlay_full.jpg", render.overlay(bgr, res.points, scale=scale))
        products["overlay_full"] = "overlay_full.jpg"
    doc = result_document(path, bgr, res, profile, products)
    write_atomic(folder / "result.json", (json.dumps(doc, indent=2) + "\n").encode())
    return doc


def _folder_for(out: Path, path: str, used: set[str]) -> Path:
    stem = Path(path).stem or "image"
    name, n = stem, 1
    while name in used:
        n += 1
        name = f"{stem}-{n}"
    used.add(name)
    return out / name


def analyze_files(
    paths: list[str], opts: AnalyzeOptions, stdout: TextIO = sys.stdout, stderr: TextIO = sys.stderr
) -> int:
    """Analyse each file; a bad file gets one line on stderr and the rest go on.

    Returns the process exit status: 0 if every file was analysed, 1 otherwise.
    """
    failed = 0
    used: set[str] = set()
    for path in paths:
        try:
            image = read_image(path)
            t0 = time.perf_counter()
            bgr, res = analyze_image(image, opts.params, opts.downsample)
            elapsed = (time.perf_counter() - t0) * 1e3
            folder = _folder_for(opts.out, path, used)
            doc = write_products(folder, path, bgr, res, opts.profile)
            _LOGGER.debug("%s: analysed in %.1f ms, stages %s", path, elapsed, res.timings_ms)
        except ImageError as exc:
            failed += 1
            print(f"cyborgd analyze: {exc}", file=stderr)
            continue
        except OSError as exc:
            failed += 1
            print(f"cyborgd analyze: {path}: cannot write products: {exc}", file=stderr)
            continue
        if opts.json_lines:
            line = {
                "image": path,
                "width": doc["width"],
                "height": doc["height"],
                "points": [{k: p[k] for k in ("rank", "x", "y", "score")} for p in doc["points"]],
                "timing_ms": round(elapsed, 3),
            }
            print(json.dumps(line), file=stdout, flush=True)
        else:
            best = ", ".join(
                f"#{p['rank']} ({p['x']:.0f}, {p['y']:.0f}) {p['score']:.2f}" for p in doc["points"]
            )
            print(f"{path}: {best or 'no interest points'} -> {folder}/", file=stdout, flush=True)
    return 1 if failed else 0


def analyse_into(
    folder: str,
    image: np.ndarray,
    profile_name: str,
    label: str,
    prior: np.ndarray | None = None,
) -> dict[str, Any]:
    """The vision worker's job: analyse a mosaic (weighted by ``prior``, memory across
    stations) and write every product into ``folder``."""
    bgr, res = analyze_image(image, profile(profile_name), prior=prior)
    return write_products(Path(folder), label, bgr, res, profile_name)
