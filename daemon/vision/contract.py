"""The vision worker's contract: the typed job the daemon sends and the typed result it gets.

Light on purpose: the service imports this module, and the science core loads only in the
worker, when :meth:`AnalysisJob.run` calls it (``job.analyse_into``). The result's fields are
``result.json``'s, in its order: :meth:`AnalysisResult.to_dict` is the document on disk.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any, ClassVar

if TYPE_CHECKING:
    import numpy as np

__all__ = ["Analysed", "AnalysisJob", "AnalysisResult", "PointsJob", "ProductsJob", "ResultPoint"]


@dataclass(frozen=True)
class ResultPoint:
    """One interest point in input pixels (pixel k's centre at k), ``result.json``'s entry."""

    rank: int
    x: float
    y: float
    radius: float
    score: float
    description: str
    summary: str
    explanation: list[dict[str, Any]]
    target: bool = True
    """False: "no further target", the score cannot be told from the view's background
    (``peaks.mark_background``); the point is kept, in rank order, and marked."""


@dataclass(frozen=True)
class AnalysisResult:
    """What one analysis found and wrote: points, classes, parameters, timings, products."""

    image: str
    width: int
    height: int
    analysed: dict[str, int]
    profile: str
    params: dict[str, Any]
    points: tuple[ResultPoint, ...]
    classes: dict[str, list[dict[str, Any]]]
    timing_ms: dict[str, float]
    products: dict[str, str]
    """Product name -> file name in the analysis folder."""
    notes: tuple[str, ...] = ()
    """What the analysis could not do and why, in plain language: a plane of one class
    (nothing in it is uncommon: with every plane alike ``paper`` has no point to give), a
    no-data fill left out (``pipeline.Analysis.notes``)."""

    def to_dict(self) -> dict[str, Any]:
        """The ``result.json`` document (a contract: field names and order as declared)."""
        return asdict(self)


@dataclass(frozen=True, eq=False)
class AnalysisJob:
    """Analyse ``image`` (a mosaic) with profile ``profile`` changed by ``settings``
    (``NAME=VALUE``), weighted by ``prior`` (memory across stations, or None), and write
    every product into ``folder``; ``label`` is the image's name in the result.
    ``no_data``, when the mosaic's maker knows it (a stitched canvas's uncovered pixels),
    is left out of the analysis as surely as the fill the science finds by itself."""

    folder: str
    image: np.ndarray
    profile: str
    label: str
    prior: np.ndarray | None = None
    settings: tuple[str, ...] = ()
    no_data: np.ndarray | None = None

    returns: ClassVar[type[AnalysisResult]] = AnalysisResult

    def run(self) -> AnalysisResult:
        """Run in the worker process: the one place the science core is imported."""
        from .job import analyse_into  # noqa: PLC0415 - the service never loads the science

        return analyse_into(self)


@dataclass(frozen=True, eq=False)
class ProductsJob:
    """Write the products and ``result.json`` of an analysis a :class:`PointsJob` made."""

    folder: str
    label: str
    profile: str
    state: bytes
    """The analysis and its input, pickled in the worker: opaque to the service."""

    returns: ClassVar[type[AnalysisResult]] = AnalysisResult

    def run(self) -> AnalysisResult:
        """Run in the worker process (see :meth:`AnalysisJob.run`)."""
        from .job import write_analysed  # noqa: PLC0415 - the service never loads the science

        return write_analysed(self)


@dataclass(frozen=True, eq=False)
class Analysed:
    """A :class:`PointsJob`'s answer: the result as ``result.json`` will hold it (its
    ``products`` still empty) and the job that writes them."""

    result: AnalysisResult
    products: ProductsJob


@dataclass(frozen=True, eq=False)
class PointsJob(AnalysisJob):
    """:class:`AnalysisJob` in two calls: this one answers as soon as the points are found,
    and the :class:`ProductsJob` of its answer draws and writes every product, so a survey
    re-points the head at the points meanwhile."""

    returns: ClassVar[type[Analysed]] = Analysed  # type: ignore[assignment]

    def run(self) -> Analysed:  # type: ignore[override]
        """Run in the worker process (see :meth:`AnalysisJob.run`)."""
        from .job import analyse_points  # noqa: PLC0415 - the service never loads the science

        return analyse_points(self)
