"""Session archive: one folder per session and station, every file whole, a manifest as truth.

Layout::

    <root>/<session>/st01-300m/manifest.json
                              tiles/r0c0.png ...   mosaic.png   chips/chip1.png ...
                              analysis/            (the science core's products, result.json)

Every file is written to a temporary name, fsynced and renamed, so a reader (or a
crash) sees the old file or the new one, never a part. The manifest lists only files
that were completely written and says whether the station is ``in-progress``,
``complete``, ``incomplete`` (cancelled or interrupted) or ``failed``. A station left
``in-progress`` by a crash is marked ``incomplete`` when the daemon next starts.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .vision.imageio import fsync_path, write_atomic, write_png

__all__ = ["Archive", "ArchiveError", "Station"]

_LOGGER = logging.getLogger(__name__)
MANIFEST = "manifest.json"
PARTIAL = ".analysis.partial"
FINAL_STATES = ("complete", "incomplete", "failed")


class ArchiveError(ValueError):
    """A request for something the archive does not hold (or may not hand out)."""


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())


@dataclass
class Station:
    """One station's folder and manifest; every write updates the manifest atomically.

    The survey's loop and the threads archiving its tiles and chips change the manifest
    alike (a station ended while a chip is still being saved): each change and the write
    that follows it hold :attr:`_lock`, so the file on disk never misses a change made
    before it and a change never lands in the middle of a write."""

    folder: Path
    manifest: dict[str, Any] = field(default_factory=dict)
    _lock: threading.RLock = field(default_factory=threading.RLock, repr=False, compare=False)

    @property
    def name(self) -> str:
        return self.folder.name

    @property
    def partial_dir(self) -> Path:
        """Where the worker writes analysis products before they are published."""
        return self.folder / PARTIAL

    def save(self) -> None:
        with self._lock:
            text = json.dumps(self.manifest, indent=1) + "\n"
            write_atomic(self.folder / MANIFEST, text.encode())

    def update(self, **fields: Any) -> None:
        with self._lock:
            self.manifest.update(fields)
            self.save()

    def amend(self, name: str, **fields: Any) -> None:
        """Add ``fields`` to the manifest's mapping ``name`` (a choice's next plan, its zoom)."""
        with self._lock:
            self.update(**{name: self.manifest[name] | fields})

    def _record(self, rel: str, size: int, entry: tuple[str, dict[str, Any]] | None = None) -> None:
        """List a whole file (and an ``entry`` under its list name) and write the manifest."""
        with self._lock:
            self.manifest.setdefault("files", {})[rel] = size
            if entry is not None:
                self.manifest.setdefault(entry[0], []).append(entry[1])
            self.save()

    def write(self, rel: str, data: bytes) -> None:
        write_atomic(self.folder / rel, data)
        self._record(rel, len(data))

    def write_png(self, rel: str, image: np.ndarray) -> None:
        self._put_png(rel, image)

    def _put_png(
        self, rel: str, image: np.ndarray, entry: tuple[str, dict[str, Any]] | None = None
    ) -> None:
        path = self.folder / rel
        write_png(path, image)
        self._record(rel, path.stat().st_size, entry)

    def add_tile(
        self,
        row: int,
        col: int,
        image: np.ndarray,
        pose: tuple[float, float],
        t: float,
        **fields: Any,
    ) -> str:
        """Archive a mosaic tile as shot and list it (pose, time, ``fields`` such as its
        registration) in the manifest; its path."""
        rel = f"tiles/r{row}c{col}.png"
        entry = {"file": rel, "row": row, "col": col, "pan": pose[0], "tilt": pose[1], "t": t}
        self._put_png(rel, image, ("tiles", entry | fields))
        return rel

    def add_chip(
        self, rank: int, image: np.ndarray, pose: tuple[float, float], t: float, **fields: Any
    ) -> str:
        """Archive the full-resolution chip of point ``rank`` and list it (pose, time,
        ``fields`` such as its centring); its path."""
        rel = f"chips/chip{rank}.png"
        entry = {"file": rel, "rank": rank, "pan": pose[0], "tilt": pose[1], "t": t}
        self._put_png(rel, image, ("chips", entry | fields))
        return rel

    def publish_analysis(self) -> list[str]:
        """Move the worker's finished products into ``analysis/`` in one rename."""
        final = self.folder / "analysis"
        if final.exists():
            shutil.rmtree(final)
        os.replace(self.partial_dir, final)
        fsync_path(self.folder)
        written = sorted(p.relative_to(self.folder).as_posix() for p in final.iterdir())
        with self._lock:
            files = self.manifest.setdefault("files", {})
            files.update((rel, (self.folder / rel).stat().st_size) for rel in written)
            self.save()
        return written

    def discard_partial(self) -> None:
        """Remove what an unfinished drawing of the products left."""
        shutil.rmtree(self.partial_dir, ignore_errors=True)

    def finish(self, status: str, reason: str = "") -> None:
        if status not in FINAL_STATES:
            raise ValueError(f"not a final station status: {status!r}")
        self.discard_partial()
        self.update(status=status, reason=reason, finished=_now())


class Archive:
    """The archive root: sessions, stations, listing and retrieval."""

    def __init__(self, root: Path, rig: str = "") -> None:
        self.root = Path(root)
        self.rig = rig

    def open(self) -> list[str]:
        """Create the root if needed; mark stations a crash left in progress, and remove the
        partial analyses it left in any station. Returns the stations marked."""
        self.root.mkdir(parents=True, exist_ok=True)
        for partial in self.root.glob(f"*/*/{PARTIAL}"):
            _LOGGER.info("removing %s, left by an interrupted analysis", partial)
            shutil.rmtree(partial, ignore_errors=True)
        recovered = []
        for manifest in sorted(self.root.glob(f"*/*/{MANIFEST}")):
            try:
                doc = json.loads(manifest.read_text())
            except (OSError, ValueError) as exc:
                _LOGGER.warning("%s: unreadable manifest left as is: %s", manifest, exc)
                continue
            if doc.get("status") not in FINAL_STATES:
                station = Station(manifest.parent, doc)
                station.finish("incomplete", "the daemon stopped during this station")
                recovered.append(f"{manifest.parent.parent.name}/{manifest.parent.name}")
        return recovered

    def new_session(self) -> str:
        base = time.strftime("%Y%m%d-%H%M%S", time.gmtime())
        name, n = base, 1
        while (self.root / name).exists():
            n += 1
            name = f"{base}-{n}"
        (self.root / name).mkdir(parents=True)
        return name

    def new_station(self, session: str, index: int, distance_m: float, **fields: Any) -> Station:
        """A station's folder and manifest: ``fields`` (its plan, site, requester, aim), then
        what the station fills in (tiles, chips, points, the choice, timing)."""
        folder = self.root / session / f"st{index:02d}-{distance_m:g}m"
        folder.mkdir(parents=True, exist_ok=False)
        station = Station(folder)
        station.update(
            format=1,
            rig=self.rig,
            session=session,
            station=folder.name,
            index=index,
            distance_m=distance_m,
            status="in-progress",
            reason="",
            started=_now(),
            finished=None,
            files={},
            **fields,
            tiles=[],
            chips=[],
            points=[],
            choice=None,
            timing={},
        )
        return station

    # -- retrieval ------------------------------------------------------------------------

    def sessions(self) -> list[str]:
        if not self.root.is_dir():
            return []
        return sorted(p.name for p in self.root.iterdir() if p.is_dir() and _public(p.name))

    def products(self, session: str) -> list[str]:
        folder = self._session(session)
        return sorted(
            p.relative_to(folder).as_posix()
            for p in folder.rglob("*")
            if p.is_file() and all(_public(part) for part in p.relative_to(folder).parts)
        )

    def read(self, session: str, product: str, max_size: int) -> bytes:
        folder = self._session(session)
        path = (folder / product).resolve()
        rel = path.relative_to(folder) if path.is_relative_to(folder) else None
        if rel is None or not all(_public(part) for part in rel.parts):
            raise ArchiveError(f"{product!r} is not a product of session {session}")
        if not path.is_file():
            raise ArchiveError(f"session {session} has no product {product!r}")
        size = path.stat().st_size
        if size > max_size:
            raise ArchiveError(f"{product} is {size} bytes, over the {max_size}-byte message limit")
        return path.read_bytes()

    def manifest(self, station_id: str) -> dict[str, Any]:
        """The manifest of station ``session/name``; ArchiveError if there is none, ValueError
        if it is not JSON."""
        session, _, name = station_id.partition("/")
        return json.loads(self.read(session, f"{name}/{MANIFEST}", 1 << 20))

    def _session(self, session: str) -> Path:
        if not session or not _public(session) or "/" in session or "\\" in session:
            raise ArchiveError(f"no session {session!r}")
        folder = (self.root / session).resolve()
        if not folder.is_dir() or folder.parent != self.root.resolve():
            raise ArchiveError(f"no session {session!r}")
        return folder


def _public(name: str) -> bool:
    """Hidden names are temporaries (atomic writes, partial analyses): never listed or served."""
    return not name.startswith(".")
