"""A station with overlap on, through the emulated head (pointing error and backlash on) and
the simulated camera: it completes with a registered mosaic and every tile's correction in
its record."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import cv2
import pytest
from test_survey_engine import _engine

from cyborg.daemon.config import SurveyConfig
from cyborg.daemon.pointing.geometry import SphericalMosaic
from cyborg.daemon.survey.approach import station_geometry
from cyborg.daemon.survey.stitch import no_data
from cyborg.daemon.vision.contract import PointsJob
from cyborg.protocol.messages import SurveyStart

pytestmark = pytest.mark.timeout(120)


async def test_an_overlapping_station_is_registered_and_recorded(tmp_path: Path) -> None:
    head = "emu://?time_scale=50&pointing_error=0.3&backlash=0.1&error_seed=7"
    async with _engine(tmp_path, SurveyConfig(overlap=0.3), head=head) as (survey, rec, archive):
        station_id = survey.start(SurveyStart(rows=2, cols=3), "tester")
        await survey._task
        assert survey.state == "awaiting-choice" and len(rec.results) == 1
        folder = survey.station.folder
        manifest = json.loads((folder / "manifest.json").read_text())
        geometry = station_geometry(archive, station_id)
    assert isinstance(geometry, SphericalMosaic) and manifest["plan"]["overlap"] == 0.3
    mosaic = cv2.imread(str(folder / "mosaic.png"))
    assert (
        (mosaic.shape[1], mosaic.shape[0])
        == geometry.size
        == (rec.results[0].width, rec.results[0].height)
    )
    fits = [tile["registration"] for tile in manifest["tiles"]]
    assert len(fits) == 6 and fits[0]["note"] == "the first tile anchors the mosaic"
    assert all(fit["registered"] and fit["confidence"] >= 0.5 for fit in fits[1:])
    assert any(abs(fit["dpan_deg"]) + abs(fit["dtilt_deg"]) > 0.05 for fit in fits[1:])
    assert "compose_s" in manifest["timing"]


async def test_seams_cut_again_off_the_points_and_the_mosaic_archived_is_the_one_analysed(
    tmp_path: Path,
) -> None:
    """The first look puts a top point near a seam of this world (seed 1): the seams are
    cut again off it and the mosaic looked at again; ``mosaic.png`` is that mosaic, so the
    science run on it anew finds exactly the points the station published."""
    head = "emu://?time_scale=50&pointing_error=0.3&backlash=0.1&error_seed=7"
    config, camera = SurveyConfig(overlap=0.3), "sim://outcrop?seed=1"
    async with _engine(tmp_path, config, camera, head) as (survey, rec, archive):
        station_id = survey.start(SurveyStart(rows=2, cols=3), "tester")
        await survey._task
        folder = survey.station.folder
        manifest = json.loads((folder / "manifest.json").read_text())
        geometry = station_geometry(archive, station_id)
    assert manifest["status"] == "complete" and manifest["seams"]["cut_again"] >= 1
    assert manifest["files"]["mosaic.png"] == (folder / "mosaic.png").stat().st_size
    mosaic = cv2.imread(str(folder / "mosaic.png"))
    job = PointsJob(str(tmp_path), mosaic, "default", "mosaic.png", None, ("aim=any",))
    again = dataclasses.replace(job, no_data=no_data(mosaic, geometry)).run().result.points
    published = rec.results[0].points
    assert [(p.x, p.y, p.score) for p in again] == [(p.x, p.y, p.score) for p in published]
