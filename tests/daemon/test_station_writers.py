"""A station's manifest has one writer at a time: the survey's loop ends a station (its
status, its timings) while a thread still archives the tile or chip it was saving, and the
manifest on disk must hold both, whole, in the order they were made."""

from __future__ import annotations

import json
import sys
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from cyborg.daemon.archive import Archive, Station

ROUNDS = 400


@pytest.fixture
def eager_switching() -> Iterator[None]:
    """Threads switch as often as the interpreter allows, so any window between a change to
    the manifest and its write is hit (the race is real either way; this makes it likely)."""
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    yield
    sys.setswitchinterval(interval)


def _station(tmp_path: Path) -> Station:
    archive = Archive(tmp_path, "test")
    archive.open()
    return archive.new_station(archive.new_session(), 1, 300.0, plan={"rows": 1, "cols": 1})


@pytest.mark.usefixtures("eager_switching")
def test_a_thread_archiving_beside_the_loop_loses_nothing(tmp_path: Path) -> None:
    station = _station(tmp_path)
    tile = np.full((8, 8, 3), 90, np.uint8)
    errors: list[BaseException] = []

    def archive_tiles() -> None:
        try:
            for k in range(ROUNDS):
                station.add_tile(0, k, tile, (0.0, 0.0), float(k))
        except BaseException as exc:
            errors.append(exc)

    thread = threading.Thread(target=archive_tiles)
    thread.start()
    try:
        for k in range(ROUNDS):
            station.update(timing={"k": k})
    finally:
        thread.join()
    station.finish("incomplete", "cancelled")
    assert errors == []
    on_disk = json.loads((station.folder / "manifest.json").read_text())
    assert on_disk == json.loads(json.dumps(station.manifest))
    assert [t["col"] for t in on_disk["tiles"]] == list(range(ROUNDS))
    assert len([f for f in on_disk["files"] if f.startswith("tiles/")]) == ROUNDS
    assert on_disk["timing"] == {"k": ROUNDS - 1} and on_disk["status"] == "incomplete"
