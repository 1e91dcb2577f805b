"""A station with overlap on, through the emulated head (pointing error and backlash on) and
the simulated camera: it completes with a registered mosaic and every tile's correction in
its record."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import pytest
from test_survey_engine import _engine

from cyborg.daemon.config import SurveyConfig
from cyborg.daemon.pointing.geometry import SphericalMosaic
from cyborg.daemon.survey.approach import station_geometry
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
