"""``cyborgd analyze``: the science core on image files, folders, globs and lists, on every
core (or a Dask cluster), every product written to disk (``products``); a bad file is
reported and the rest go on.

Results come out in input order, as they would sequentially: on stdout one line per image,
in ``OUT/summary.jsonl`` one JSON line per image, flushed as it arrives, so a killed run
keeps what it did and ``--resume`` takes it from there.
"""

from __future__ import annotations

import glob
import json
import logging
import multiprocessing
import os
import sys
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import TextIO

from ..vision.params import VisionParams
from .batch import ImageOutcome, ImageTask, analyze_one, pool_process_start
from .cluster import ClusterError, cluster_executor
from .progress import Progress

_LOGGER = logging.getLogger(__name__)

__all__ = ["IMAGE_SUFFIXES", "AnalyzeOptions", "analyze_files", "expand_inputs"]

IMAGE_SUFFIXES = frozenset(
    {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".webp", ".pgm", ".ppm", ".pnm"}
)
"""What a folder or a glob contributes (case-insensitive); a file named outright is always
tried, whatever its name."""

SUMMARY = "summary.jsonl"


@dataclass(frozen=True)
class AnalyzeOptions:
    out: Path
    profile: str
    params: VisionParams
    downsample: float | None = None
    """None: the profile's working size (``max_pixels``)."""
    json_lines: bool = False
    jobs: int | None = None
    """Local processes; None: one per core."""
    products: str = "all"
    resume: bool = False
    scheduler: str | None = None
    """A Dask scheduler's address: the workers analyse, this process plans and reports."""


def _images_under(folder: Path) -> list[str]:
    return sorted(
        str(p)
        for p in folder.rglob("*")
        if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file() and not p.name.startswith(".")
    )


def expand_inputs(specs: Iterable[str]) -> list[tuple[str, str]]:
    """Files as given, folders walked (image files, sorted), globs expanded by us (``**``
    recurses; quote them so the shell leaves them alone). Returns (image, "") pairs and, in
    their place, (input, error) for a folder or a glob without images; a file is left for
    the reader to judge.

    >>> expand_inputs(["a.png", "/nonexistent/*.png"])
    [('a.png', ''), ('/nonexistent/*.png', '/nonexistent/*.png: no image matches')]
    """
    found: list[tuple[str, str]] = []
    for spec in specs:
        if any(c in spec for c in "*?["):
            images = sorted(
                p
                for p in glob.glob(spec, recursive=True)
                if Path(p).suffix.lower() in IMAGE_SUFFIXES and Path(p).is_file()
            )
            found += [(p, "") for p in images] or [(spec, f"{spec}: no image matches")]
        elif Path(spec).is_dir():
            images = _images_under(Path(spec))
            found += [(p, "") for p in images] or [(spec, f"{spec}: no image files in it")]
        else:
            found.append((spec, ""))
    return found


def read_list(path: str) -> list[str]:
    """The inputs a list file names, one per line (``-``: standard input); blank lines and
    lines starting with ``#`` are skipped. Raises OSError."""
    if path == "-":
        lines = sys.stdin.read().splitlines()
    else:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    return [s for line in lines if (s := line.strip()) and not s.startswith("#")]


def _folder_for(out: Path, path: str, used: set[str]) -> Path:
    stem = Path(path).stem or "image"
    name, n = stem, 1
    while name in used:
        n += 1
        name = f"{stem}-{n}"
    used.add(name)
    return out / name


_Submit = Callable[[ImageTask], "Future[ImageOutcome]"]


def _in_order(
    submit: _Submit,
    entries: Iterable[ImageTask | ImageOutcome],
    window: int,
) -> Iterator[tuple[ImageTask | ImageOutcome, Future[ImageOutcome]]]:
    """Submit ahead by ``window`` tasks and hand back each in input order (an outcome known
    beforehand, in its place): the processes stay busy, memory stays bounded however long
    the archive, and the output reads as a sequential run's."""
    pending: deque[tuple[ImageTask | ImageOutcome, Future[ImageOutcome]]] = deque()
    try:
        for entry in entries:
            if isinstance(entry, ImageTask):
                pending.append((entry, submit(entry)))
            else:
                known: Future[ImageOutcome] = Future()
                known.set_result(entry)
                pending.append((entry, known))
            if len(pending) >= window:
                yield pending.popleft()
        while pending:
            yield pending.popleft()
    finally:
        for _, future in pending:
            future.cancel()


def _run_here(task: ImageTask) -> Future[ImageOutcome]:
    """One process: the task run here and now (one image, or ``--jobs 1``)."""
    future: Future[ImageOutcome] = Future()
    try:
        future.set_result(analyze_one(task))
    except Exception as exc:  # reported per image, as from a pool
        future.set_exception(exc)
    return future


def _cores() -> int:
    """The cores this process may run on (a container's or taskset's limit, not the host's)."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


@contextmanager
def _runner(opts: AnalyzeOptions, count: int) -> Iterator[tuple[_Submit, int]]:
    """How tasks are run and how many to keep in flight: on a Dask cluster, in one process
    per core, or (one process is enough) here."""
    if opts.scheduler:
        with cluster_executor(opts.scheduler) as (executor, window):
            yield partial(executor.submit, analyze_one), window
        return
    jobs = min(opts.jobs or _cores(), count)
    if jobs <= 1:
        yield _run_here, 1
        return
    # spawn: the children start clean, whatever threads (zenoh, BLAS) this process holds
    context = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(jobs, mp_context=context, initializer=pool_process_start)
    try:
        yield partial(pool.submit, analyze_one), 4 * jobs
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _outcome(entry: ImageTask | ImageOutcome, future: Future[ImageOutcome]) -> ImageOutcome:
    try:
        return future.result()
    except Exception as exc:
        _LOGGER.debug("%s: analysis failed", entry.image, exc_info=True)
        error = f"{entry.image}: analysis failed: {type(exc).__name__}: {exc}"
        return ImageOutcome(entry.image, entry.folder, "failed", error)


def analyze_files(
    inputs: list[str],
    opts: AnalyzeOptions,
    stdout: TextIO = sys.stdout,
    stderr: TextIO = sys.stderr,
) -> int:
    """Analyse every image the inputs name; a bad file gets one line on stderr and the rest
    go on. On a terminal, stderr shows k/N, rate and ETA on one updating line.

    Returns the process exit status: 0 if every image was analysed (or kept, with
    ``--resume``), 1 otherwise, 130 if interrupted.
    """
    used: set[str] = set()
    entries = [
        ImageOutcome(path, "", "failed", error)
        if error
        else ImageTask(
            path,
            str(_folder_for(opts.out, path, used)),
            opts.profile,
            opts.params,
            opts.downsample,
            opts.products,
            opts.resume,
        )
        for path, error in expand_inputs(inputs)
    ]
    try:
        opts.out.mkdir(parents=True, exist_ok=True)
        summary = (opts.out / SUMMARY).open("w", encoding="utf-8")
    except OSError as exc:
        print(f"cyborgd analyze: {opts.out}: cannot write products: {exc}", file=stderr)
        return 1
    progress = Progress(len(entries), stderr) if stderr.isatty() else None
    shared_screen = progress is not None and stdout.isatty()
    failed = 0
    try:
        tasks = sum(isinstance(e, ImageTask) for e in entries)
        with summary, _runner(opts, tasks) as (submit, window):
            for entry, future in _in_order(submit, entries, window):
                outcome = _outcome(entry, future)
                summary.write(json.dumps(outcome.summary_line()) + "\n")
                summary.flush()
                if outcome.status == "failed":
                    failed += 1
                    if progress:
                        progress.clear()
                    print(f"cyborgd analyze: {outcome.error}", file=stderr)
                else:
                    if progress and shared_screen:
                        progress.clear()
                    _print_result(outcome, opts.json_lines, stdout)
                if progress:
                    progress.advance()
    except ClusterError as exc:
        print(f"cyborgd analyze: {exc}", file=stderr)
        return 1
    except KeyboardInterrupt:
        if progress:
            progress.clear()
        print(
            f"cyborgd analyze: interrupted; {opts.out / SUMMARY} holds what was done, "
            "--resume with the same inputs takes it from there",
            file=stderr,
        )
        return 130
    finally:
        if progress:
            progress.close()
    return 1 if failed else 0


def _print_result(outcome: ImageOutcome, json_lines: bool, stdout: TextIO) -> None:
    if json_lines:
        print(json.dumps(outcome.json_line()), file=stdout, flush=True)
        return
    best = ", ".join(
        f"#{p['rank']} ({p['x']:.0f}, {p['y']:.0f}) {p['score']:.2f}" for p in outcome.points
    )
    kept = " (kept from an earlier run)" if outcome.status == "skipped" else ""
    print(
        f"{outcome.image}: {best or 'no interest points'} -> {outcome.folder}/{kept}",
        file=stdout,
        flush=True,
    )
