"""A station whose head moves on while its files are still being written: the last tile and
the mosaic are archived while the worker analyses, and the worker draws the analysis's
products while the head goes to the chips. Once the station says it is complete, every file
is on disk as listed, and the record says what the analysis found and wrote; the analysis
in two calls (points, then products) writes what it writes in one."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np
import pytest
from test_survey_engine import _engine

from cyborg.daemon.config import SurveyConfig
from cyborg.daemon.vision.contract import AnalysisJob, PointsJob
from cyborg.protocol.messages import SurveyStart

pytestmark = pytest.mark.timeout(180)


@pytest.mark.parametrize("overlap", [0.0, 0.3], ids=["butted", "registered"])
async def test_a_complete_station_has_every_file_on_disk_as_listed(
    tmp_path: Path, overlap: float
) -> None:
    async with _engine(tmp_path, SurveyConfig(overlap=overlap)) as (survey, rec, _):
        survey.start(SurveyStart(rows=2, cols=3), "tester")
        await survey._task
        folder = survey.station.folder
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["status"] == "complete" and len(rec.results) == 1
    files = manifest["files"]
    for rel, size in files.items():
        assert (folder / rel).stat().st_size == size, rel
    on_disk = {p.relative_to(folder).as_posix() for p in (folder / "analysis").iterdir()}
    assert on_disk == {rel for rel in files if rel.startswith("analysis/")}
    assert not (folder / ".analysis.partial").exists()
    assert [t["file"] for t in manifest["tiles"]] == [
        f"tiles/r{r}c{c}.png" for r, c in manifest["plan"]["order"]
    ]
    assert {"mosaic.png", *(t["file"] for t in manifest["tiles"])} <= set(files)
    assert [c["rank"] for c in manifest["chips"]] == [1, 2, 3]
    assert all(c["file"] in files for c in manifest["chips"])
    result = json.loads((folder / "analysis" / "result.json").read_text())
    assert result["products"] == manifest["products"] and "overlay" in result["products"]
    assert [(p["rank"], p["x"], p["y"]) for p in result["points"]] == [
        (p["rank"], p["x"], p["y"]) for p in manifest["points"]
    ]
    assert {"analysis_s", "products_s", "wall_s"} <= set(manifest["timing"])


@pytest.mark.parametrize("profile", ["default", "paper"])
def test_the_analysis_in_two_calls_writes_what_one_call_writes(
    tmp_path: Path, rng: np.random.Generator, profile: str
) -> None:
    image = rng.integers(90, 130, (120, 200, 3), dtype=np.uint8)
    image[40:60, 120:150] = (40, 160, 40)
    one = AnalysisJob(str(tmp_path / "one"), image, profile, "mosaic.png").run()
    first = PointsJob(str(tmp_path / "two"), image, profile, "mosaic.png").run()
    assert first.result.products == {} and first.result.points == one.points
    two = pickle.loads(pickle.dumps(first.products)).run()  # as it travels to the worker
    docs = [json.loads((tmp_path / name / "result.json").read_text()) for name in ("one", "two")]
    for doc in docs:
        del doc["timing_ms"]
    assert docs[0] == docs[1] and two.products == one.products
    for name in one.products.values():
        assert (tmp_path / "two" / name).read_bytes() == (tmp_path / "one" / name).read_bytes()
