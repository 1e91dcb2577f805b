"""``cyborgd analyze``: the science core on image files, every product written to disk
(``products``); a bad file is reported and the rest go on."""

from __future__ import annotations

import json
import logging
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from ..vision.imageio import ImageError, read_image
from ..vision.job import analyze_image, write_products
from ..vision.params import VisionParams

_LOGGER = logging.getLogger(__name__)

__all__ = ["AnalyzeOptions", "analyze_files"]


@dataclass(frozen=True)
class AnalyzeOptions:
    out: Path
    profile: str
    params: VisionParams
    downsample: float | None = None
    """None: the profile's working size (``max_pixels``)."""
    json_lines: bool = False


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
                "width": doc.width,
                "height": doc.height,
                "points": [
                    {"rank": p.rank, "x": p.x, "y": p.y, "score": p.score} for p in doc.points
                ],
                "timing_ms": round(elapsed, 3),
            }
            print(json.dumps(line), file=stdout, flush=True)
        else:
            best = ", ".join(f"#{p.rank} ({p.x:.0f}, {p.y:.0f}) {p.score:.2f}" for p in doc.points)
            print(f"{path}: {best or 'no interest points'} -> {folder}/", file=stdout, flush=True)
    return 1 if failed else 0
