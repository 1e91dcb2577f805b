"""The per-image job of ``cyborgd analyze``: one image read, analysed and written, wherever it
runs (inline, in one of the local per-core processes or on a Dask worker).

The task carries a path, not pixels: each process reads its own image and writes its own
folder, so only small messages cross process and machine boundaries. Light on purpose: the
science core is imported where the job runs, not where it is planned.
"""

from __future__ import annotations

import json
import logging
import signal
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..vision.params import VisionParams

_LOGGER = logging.getLogger(__name__)

__all__ = ["PRODUCTS", "ImageOutcome", "ImageTask", "analyze_one", "pool_process_start"]

PRODUCTS = ("all", "overlay", "none")
"""What ``--products`` may ask for (``job.write_products``); result.json is always written."""

_NEEDS = {"all": "interest", "overlay": "overlay", "none": None}
"""A product every result.json written with this ``--products`` lists (``--resume``)."""

_POINT = ("rank", "x", "y", "score", "target")
"""A point's fields in the summary (all but the explanations, which result.json holds)."""

_process_ready = False


def setup_process() -> None:
    """Once per process, before its first analysis: one native thread per process (every
    process already owns a core)."""
    global _process_ready  # noqa: PLW0603 - once per process, wherever the job runs
    if not _process_ready:
        from ..vision.threads import single_thread  # noqa: PLC0415 - analysis processes only

        single_thread()
        _process_ready = True


def pool_process_start() -> None:
    """Initializer of the local per-core processes: Ctrl-C is the parent's to handle (it
    stops the run and says how to resume), then :func:`setup_process`."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    setup_process()


@dataclass(frozen=True)
class ImageTask:
    """Analyse ``image`` into ``folder``; ``resume``: keep the folder's earlier result if it
    is complete and made with the same profile, parameters and products."""

    image: str
    folder: str
    profile: str
    params: VisionParams
    downsample: float | None = None
    products: str = "all"
    resume: bool = False


@dataclass(frozen=True)
class ImageOutcome:
    """What one task did: ``status`` done, skipped (``--resume``) or failed (``error``)."""

    image: str
    folder: str
    status: str
    error: str = ""
    width: int = 0
    height: int = 0
    points: tuple[dict[str, Any], ...] = ()
    """rank, x, y (input pixels), score, target."""
    timing_ms: dict[str, float] = field(default_factory=dict)
    """analysis (the science core alone) and write (every product, synced)."""

    def summary_line(self) -> dict[str, Any]:
        """The line of ``summary.jsonl`` (a contract: one per image, fields in this order)."""
        line = {"image": self.image, "folder": self.folder, "status": self.status}
        if self.error:
            line["error"] = self.error
        else:
            line.update(width=self.width, height=self.height, points=list(self.points))
            line["timing_ms"] = self.timing_ms
        return line

    def json_line(self) -> dict[str, Any]:
        """The ``--json`` line on stdout (a contract kept from the sequential command)."""
        return {
            "image": self.image,
            "width": self.width,
            "height": self.height,
            "points": [{k: p[k] for k in ("rank", "x", "y", "score")} for p in self.points],
            "timing_ms": self.timing_ms.get("analysis", 0.0),
        }


def _earlier(task: ImageTask) -> dict[str, Any] | None:
    """The folder's result.json if it answers this very task, else None (a missing, partial
    or unreadable folder, another image, other parameters or fewer products: analyse)."""
    try:
        doc = json.loads((Path(task.folder) / "result.json").read_bytes())
    except (OSError, ValueError):
        return None
    params = json.loads(json.dumps(task.params.to_dict()))
    need = _NEEDS[task.products]
    same = (doc.get("image"), doc.get("profile"), doc.get("params")) == (
        task.image,
        task.profile,
        params,
    )
    return doc if same and (need is None or need in doc.get("products", {})) else None


def analyze_one(task: ImageTask) -> ImageOutcome:
    """Read, analyse and write one image; a bad file or an unwritable folder is an outcome
    with its one-line error, never an exception."""
    from ..vision.imageio import ImageError, read_image  # noqa: PLC0415 - science where it runs
    from ..vision.job import analyze_image, write_products  # noqa: PLC0415 - idem

    setup_process()
    if task.resume and (doc := _earlier(task)) is not None:
        points = tuple({k: p[k] for k in _POINT} for p in doc["points"])
        return ImageOutcome(
            task.image, task.folder, "skipped", "", doc["width"], doc["height"], points
        )
    try:
        image = read_image(task.image)
        t0 = time.perf_counter()
        bgr, res = analyze_image(image, task.params, task.downsample)
        t1 = time.perf_counter()
        result = write_products(
            Path(task.folder), task.image, bgr, res, task.profile, products=task.products
        )
        t2 = time.perf_counter()
    except ImageError as exc:
        return ImageOutcome(task.image, task.folder, "failed", str(exc))
    except OSError as exc:
        error = f"{task.image}: cannot write products: {exc}"
        return ImageOutcome(task.image, task.folder, "failed", error)
    _LOGGER.debug("%s: analysed in %.1f ms, stages %s", task.image, (t1 - t0) * 1e3, res.timings_ms)
    timing = {"analysis": round((t1 - t0) * 1e3, 3), "write": round((t2 - t1) * 1e3, 3)}
    points = tuple({k: getattr(p, k) for k in _POINT} for p in result.points)
    return ImageOutcome(
        task.image, task.folder, "done", "", result.width, result.height, points, timing
    )
