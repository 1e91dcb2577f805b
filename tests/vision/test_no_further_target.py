"""A point whose score cannot be told from the view's background is kept, in its place, and
marked "no further target"; a real target, however much weaker than the best, never is."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from bench.targets import generated, tally
from cyborg.daemon.vision.contract import AnalysisJob
from cyborg.daemon.vision.job import analyze_image
from cyborg.daemon.vision.params import PROFILES
from cyborg.daemon.vision.peaks import SHARE, SPREADS, find_points
from cyborg.daemon.vision.pipeline import NO_TARGET


def _rock(seed: int = 1) -> np.ndarray:
    """Plain buff rock with sensor noise, (288, 540, 3) BGR."""
    rng = np.random.default_rng(seed)
    rock = np.full((288, 540, 3), (120, 150, 170), np.float64)
    return np.clip(rock + rng.normal(0.0, 3.0, rock.shape), 0, 255).astype(np.uint8)


def _one_plant() -> np.ndarray:
    image = _rock()
    image[130:160, 300:330] = (40, 160, 40)
    return image


@pytest.mark.parametrize("profile", ["default", "paper", "uncommon"])
def test_noise_beside_one_target_is_marked_and_kept_in_order(profile: str) -> None:
    params = PROFILES[profile]
    _, res = analyze_image(_one_plant(), params)
    assert res.points[0].target
    assert res.descriptions[0] != NO_TARGET
    for p, line in zip(res.points[1:], res.descriptions[1:], strict=True):
        assert not p.target and line == NO_TARGET, (p, line)
    # Marking moves nothing: the same points, in the same order, as the peaks alone.
    found = find_points(res.interest, params)
    assert [(p.rank, p.x, p.y, p.score) for p in res.points] == [
        (p.rank, p.x, p.y, p.score) for p in found
    ]


def test_a_faint_second_target_is_still_a_target() -> None:
    """A pale grey spot scoring a fourteenth of the plant is a target; the noise is not."""
    image = _one_plant()
    cv2.circle(image, (100, 220), 6, (150, 150, 150), -1)
    _, res = analyze_image(image, PROFILES["default"])
    plant, spot, noise = res.points
    assert spot.score < plant.score / 10 and np.hypot(spot.x - 100, spot.y - 220) < 25
    assert (plant.target, spot.target, noise.target) == (True, True, False)


@pytest.mark.parametrize("shape", [(1, 5000), (5000, 1)])
def test_a_strip_has_no_target(shape: tuple[int, int]) -> None:
    """A row of plain rock stretched to 1 x 5000 (or a column to 5000 x 1): every point the
    frame discounts to a score of 0 is background."""
    strip = cv2.resize(_rock()[100:101], shape[::-1], interpolation=cv2.INTER_LINEAR)
    _, res = analyze_image(strip, PROFILES["default"])
    assert res.points and not any(p.target for p in res.points), res.points


def test_result_json_keeps_the_marked_points_marked(tmp_path: Path) -> None:
    result = AnalysisJob(str(tmp_path), _one_plant(), "default", "plant.png").run()
    doc = json.loads((tmp_path / "result.json").read_text())
    assert [p["rank"] for p in doc["points"]] == [1, 2, 3]
    assert [p["target"] for p in doc["points"]] == [True, False, False]
    assert [p.target for p in result.points] == [True, False, False]
    assert doc["points"][1]["description"] == NO_TARGET


def test_the_benchmark_counts_what_the_rule_hides() -> None:
    """``bench.targets`` on a few generated scenes: the strips are all marked, no planted
    target is lost, and its counts add up."""
    views = list(generated("default", 2, 0))
    table = tally(views, SPREADS, SHARE)
    strip, whole = table["strip"], table["all"]
    assert strip["points"] > 0 and strip["misses_marked"] == strip["points"]
    assert whole["lost"] == whole["hits_marked"] == 0
    assert whole["points"] == whole["hits"] + whole["misses"] == sum(len(v.points) for v in views)
