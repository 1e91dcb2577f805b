"""One image through the science core at its working size, and every product on disk.

What the vision worker runs for an :class:`~.contract.AnalysisJob` (:func:`analyse_into`;
the job itself lives in the light ``contract`` module, so the service never imports the
science core) and what the ``cyborgd analyze`` command, the demo and the benchmarks run
(:func:`analyze_image`).
"""

from __future__ import annotations

import json
import math
import pickle
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ..pointing.geometry import pixel_centre, pixel_index
from . import render
from .contract import Analysed, AnalysisJob, AnalysisResult, PointsJob, ProductsJob, ResultPoint
from .exact import exact
from .explain import PLANE_NAMES, describe
from .grid import reduce_to
from .imageio import as_bgr8, fsync_path, write_atomic, write_jpeg, write_png
from .interest import InterestPoint
from .params import VisionParams, profile, with_settings
from .pipeline import Analysis, analyze
from .uncommon import uncommon_map

__all__ = [
    "analyse_into",
    "analyse_points",
    "analyze_image",
    "input_points",
    "result_document",
    "working_reduction",
    "write_analysed",
    "write_products",
]


def working_reduction(shape: tuple[int, ...], params: VisionParams) -> float:
    """How much to reduce an image of this shape before analysis: 1 up to ``max_pixels``.

    >>> from cyborg.daemon.vision.params import DEFAULT
    >>> working_reduction((3000, 4000), DEFAULT) > 3.0, working_reduction((300, 400), DEFAULT)
    (True, 1.0)
    """
    pixels = shape[0] * shape[1]
    if not params.max_pixels or pixels <= params.max_pixels:
        return 1.0
    return math.sqrt(pixels / params.max_pixels)


@exact
def analyze_image(
    image: np.ndarray,
    params: VisionParams,
    downsample: float | None = None,
    prior: np.ndarray | None = None,
    no_data: np.ndarray | None = None,
) -> tuple[np.ndarray, Analysis]:
    """Normalise, reduce (as the seed did, 4-8x; by default to the profile's working size),
    analyse (with ``prior`` weights over the same ground and the ``no_data`` known of the
    image, ``pipeline.analyze``); returns (bgr, analysis)."""
    bgr = as_bgr8(image)
    if downsample is None:
        downsample = working_reduction(bgr.shape, params)
    work = bgr
    if downsample != 1.0:
        rows, cols = bgr.shape[:2]
        size = (max(1, int(cols / downsample)), max(1, int(rows / downsample)))
        work = reduce_to(bgr, size)
        if no_data is not None:  # a reduced pixel with any no-data in it is no-data
            no_data = reduce_to(no_data.astype(np.float32), size) > 0
    return bgr, analyze(work, params, prior, no_data)


def _to_input(value: float, scale: float) -> float:
    """Analysed-pixel coordinate -> input-pixel coordinate (pixel centres line up)."""
    return pixel_index(pixel_centre(value) * scale)


def input_points(shape: tuple[int, ...], res: Analysis) -> list[InterestPoint]:
    """The analysis's points in the pixels of an input of this shape (it may have been
    reduced before analysis)."""
    arows, acols = res.hsi.i.shape
    sx, sy = shape[1] / acols, shape[0] / arows
    return [
        InterestPoint(
            p.rank, _to_input(p.x, sx), _to_input(p.y, sy), p.score, p.radius * sx, p.target
        )
        for p in res.points
    ]


def result_document(
    path: str, bgr: np.ndarray, res: Analysis, profile: str, products: dict[str, str]
) -> AnalysisResult:
    """The ``result.json`` contents: points in input pixels, classes, parameters, timings,
    and the analysis's notes (a plane of one class says so instead of a silent empty list)."""
    rows, cols = bgr.shape[:2]
    arows, acols = res.hsi.i.shape
    found = input_points(bgr.shape, res)
    points = tuple(
        ResultPoint(
            p.rank,
            round(p.x, 2),
            round(p.y, 2),
            round(p.radius, 2),
            round(p.score, 4),
            line,
            describe(expl),
            expl,
            p.target,
        )
        for p, expl, line in zip(found, res.explanations, res.descriptions, strict=True)
    )
    classes = {
        name: [
            {"label": k, "value": seg.original_value(c.center), "radius": c.radius, "area": c.area}
            for k, c in enumerate(seg.classes, start=1)
        ]
        for name, seg in zip(PLANE_NAMES, res.segmentations, strict=True)
    }
    return AnalysisResult(
        path,
        cols,
        rows,
        {"width": acols, "height": arows},
        profile,
        res.params.to_dict(),
        points,
        classes,
        {k: round(v, 3) for k, v in res.timings_ms.items()},
        products,
        res.notes,
    )


def _sync_all(folder: Path, names: list[str]) -> None:
    """fsync these files of a folder, and the folder, together: the flushes overlap, where
    one fsync after each file would wait for each in turn."""

    targets = [*(folder / name for name in names), folder]
    with ThreadPoolExecutor(max_workers=min(16, len(targets))) as pool:
        list(pool.map(fsync_path, targets))


def write_products(
    folder: Path, path: str, bgr: np.ndarray, res: Analysis, profile: str, *, products: str = "all"
) -> AnalysisResult:
    """Write the products, then result.json: ``all`` planes, segmentations, co-occurrence
    plots, maps, figures and the overlay; ``overlay`` the overlay only; ``none`` no image.

    result.json marks the folder complete: it is removed first and written last, atomically,
    once every product is on disk (one overlapped fsync for them all), so a crash leaves a
    complete folder or one without result.json, never one that counts as done and is not.
    """
    params = res.params
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "result.json").unlink(missing_ok=True)
    written: dict[str, str] = {}

    def put(name: str, image: np.ndarray) -> None:
        write_png(folder / name, image, sync=False)
        written[name.removesuffix(".png")] = name

    if products == "all":
        for name, plane, seg in zip(PLANE_NAMES, res.hsi.planes, res.segmentations, strict=True):
            low = name.lower()
            put(f"plane_{low}.png", plane)
            put(f"segmentation_{low}.png", render.segmentation_image(seg))
            put(f"cooccurrence_{low}.png", render.cooccurrence_plot(seg))
            umap = uncommon_map(seg, params)
            put(f"uncommon_{low}.png", render.grey_ramp(umap, vmax=8.0))
            # the same maps as figures, each with its scale: the files above are data
            put(f"figure_segmentation_{low}.png", render.class_figure(seg, f"segmentation {name}"))
            put(f"figure_uncommon_{low}.png", render.map_figure(umap, f"uncommon {name}", 8.0))
        interest = np.maximum(res.interest.full(), 0.0)
        put("interest.png", render.grey_ramp(interest))
        put("figure_interest.png", render.map_figure(interest, "interest"))
    if products != "none":
        scale = bgr.shape[1] / res.hsi.i.shape[1]
        if scale == 1.0:
            put("overlay.png", render.overlay(bgr, res.points, notes=res.notes))
        else:  # a big input: the overlay at the analysed size, and a JPEG at full size
            small = reduce_to(bgr, res.hsi.i.shape[::-1])
            put("overlay.png", render.overlay(small, res.points, notes=res.notes))
            full = render.overlay(bgr, res.points, scale=scale, notes=res.notes)
            write_jpeg(folder / "overlay_full.jpg", full, sync=False)
            written["overlay_full"] = "overlay_full.jpg"
    _sync_all(folder, list(written.values()))
    result = result_document(path, bgr, res, profile, written)
    write_atomic(folder / "result.json", (json.dumps(result.to_dict(), indent=2) + "\n").encode())
    return result


def _analyse(job: AnalysisJob) -> tuple[np.ndarray, Analysis]:
    """The job's mosaic (weighted by its ``prior``, memory across stations) analysed with
    its profile changed by its ``settings`` (the rig's ``survey.settings``)."""
    params = with_settings(profile(job.profile), list(job.settings))
    return analyze_image(job.image, params, prior=job.prior, no_data=job.no_data)


def analyse_into(job: AnalysisJob) -> AnalysisResult:
    """The vision worker's analysis (:func:`_analyse`), every product written into the
    job's ``folder``."""
    return write_products(Path(job.folder), job.label, *_analyse(job), job.profile)


def analyse_points(job: PointsJob) -> Analysed:
    """:func:`analyse_into` up to the points; the answer's job writes the products."""
    bgr, res = _analyse(job)
    later = ProductsJob(job.folder, job.label, job.profile, pickle.dumps((bgr, res), protocol=5))
    return Analysed(result_document(job.label, bgr, res, job.profile, {}), later)


def write_analysed(job: ProductsJob) -> AnalysisResult:
    """The products and ``result.json`` of an analysis :func:`analyse_points` made."""
    bgr, res = pickle.loads(job.state)  # no new trust: the pipe carrying it is pickle too
    return write_products(Path(job.folder), job.label, bgr, res, job.profile)
