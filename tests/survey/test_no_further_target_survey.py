"""A station whose view holds one target: the points beside it that the analysis marks as
background ("no further target") stay in the record, marked, get no chip and cannot be
chosen (the survey engine in-process, emulated PTU, a real worker process)."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from cyborg.daemon.vision.imageio import write_png
from cyborg.protocol.messages import ChooseTarget, SurveyStart
from tests.survey.test_survey_engine import _engine

pytestmark = pytest.mark.timeout(120)


def _plain_rock_with_a_plant(path: Path) -> str:
    """A panorama of plain buff rock (sensor noise only) with one green plant near its
    middle; its camera URL (80 x 52 degrees)."""
    rng = np.random.default_rng(5)
    pano = np.full((1040, 1600, 3), (120, 150, 170), np.float64)
    pano = np.clip(pano + rng.normal(0.0, 3.0, pano.shape), 0, 255).astype(np.uint8)
    cv2.circle(pano, (880, 520), 30, (40, 160, 40), -1)
    write_png(path, pano)
    return f"sim://{path}?pan=-40,40&tilt=-26,26"


async def test_background_points_get_no_chip_and_cannot_be_chosen(tmp_path: Path) -> None:
    camera = _plain_rock_with_a_plant(tmp_path / "plant.png")
    async with _engine(tmp_path, camera=camera) as (survey, rec, _):
        survey.start(SurveyStart(rows=1, cols=2), "tester")
        await survey._task
        result = survey._result
        assert [p.target for p in result.points] == [True, False, False], result.points
        assert [c.rank for c in rec.chips] == [1]
        record = json.loads((survey.station.folder / "analysis/result.json").read_text())
        assert [p["target"] for p in record["points"]] == [True, False, False]
        manifest = survey.station.manifest["points"]
        assert [(p["rank"], p["target"]) for p in manifest] == [(1, True), (2, False), (3, False)]
        with pytest.raises(ValueError, match=r"point 2 .* is no further target"):
            await survey.choose(ChooseTarget(result.station, 2), "tester")
        assert survey.state == "awaiting-choice"
        ack = await survey.choose(ChooseTarget(result.station, 1), "tester")
        assert ack.startswith("target 1 chosen")
