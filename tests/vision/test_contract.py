"""The worker's contract: a typed job, a typed result, and ``result.json`` is that result."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from cyborg.daemon.vision.contract import AnalysisJob, AnalysisResult, ResultPoint

FIELDS = [
    "image",
    "width",
    "height",
    "analysed",
    "profile",
    "params",
    "points",
    "classes",
    "timing_ms",
    "products",
    "notes",
]
POINT_FIELDS = [
    "rank",
    "x",
    "y",
    "radius",
    "score",
    "description",
    "summary",
    "explanation",
    "target",
]


def test_the_result_is_typed_and_result_json_is_it_field_for_field(tmp_path: Path) -> None:
    image = np.full((60, 80, 3), (60, 110, 160), np.uint8)
    image[25:35, 50:60] = (40, 160, 40)
    job = AnalysisJob(str(tmp_path), image, "default", "mosaic.png", settings=("top_n=1",))
    result = job.run()
    assert isinstance(result, job.returns) and isinstance(result, AnalysisResult)
    assert len(result.points) == 1 and all(isinstance(p, ResultPoint) for p in result.points)
    doc = json.loads((tmp_path / "result.json").read_text())
    assert list(doc) == FIELDS and list(doc["points"][0]) == POINT_FIELDS
    assert doc == json.loads(json.dumps(result.to_dict()))
    assert (doc["image"], doc["profile"], doc["params"]["top_n"]) == ("mosaic.png", "default", 1)
    assert doc["products"] == result.products and (tmp_path / result.products["interest"]).is_file()
