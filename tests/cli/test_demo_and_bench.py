"""Smoke tests: the demo writes its products; the benchmarks run on a few inputs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bench import browser, bus, operator, ptu, quality, speed, survey
from daemon.demo import run_demo
from daemon.scene import outcrop_scene
from daemon.vision.interest import InterestPoint


def test_demo_writes_everything(tmp_path, capsys):
    assert run_demo(tmp_path, seed=7) == 0
    out = capsys.readouterr().out
    for profile in ("default", "paper"):
        folder = tmp_path / profile / "scene"
        assert (folder / "sheet.png").exists() and (folder / "overlay.png").exists()
        assert json.loads((folder / "result.json").read_text())["profile"] == profile
        assert str(folder) in out
    assert len(json.loads((tmp_path / "targets.json").read_text())) == 3


def test_quality_benchmark_smoke():
    results = quality.run(n_scenes=3, seed=0, tolerance=6.0)
    assert set(results) == {"default", "paper", "spectral-residual", "rx-anomaly", "random"}
    for row in results.values():
        for key in ("top1", "any3", "precision3", "shadow3", "repeat1"):
            assert 0.0 <= row[key] <= 1.0


def test_second_looks_are_fresh_but_reproducible_and_repeats_compares_best_points():
    scene = outcrop_scene(4)
    first, second = quality.second_looks(scene)
    again = quality.second_looks(scene)
    assert not np.array_equal(first.image, scene.image)
    assert not np.array_equal(first.image, second.image)
    assert np.array_equal(first.image, again[0].image)
    # Fresh noise, not a new scene: the looks stay close to the original.
    assert np.abs(first.image.astype(int) - scene.image).mean() < 3.0
    here, there = InterestPoint(1, 10.0, 10.0, 1.0), InterestPoint(1, 30.0, 10.0, 1.0)
    assert quality.repeats([here], [InterestPoint(1, 13.0, 14.0, 0.5), there], 6.0)
    assert not quality.repeats([here], [there, here], 6.0)
    assert not quality.repeats([], [here], 6.0)


def test_speed_benchmark_smoke():
    rows = speed.run(sizes={"tiny": (54, 96)}, repeats=1)
    assert rows[0]["name"] == "tiny" and rows[0]["ms"] > 0 and rows[0]["floor_ms"] > 0


def test_ptu_benchmark_smoke(capsys):
    assert ptu.main(["--queries", "5", "--time-scale", "20", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["round_trip"]) >= {"pty, paced at 9600 baud", "in-process emulator (baseline)"}
    assert len(out["moves"]) == len(ptu.MOVES)
    for move in out["moves"]:
        # At 20x, the reply's line time alone is ~60 ms emulated; the model is the floor.
        assert move["measured_s"] >= move["predicted_s"] - 0.01


@pytest.mark.timeout(120)
def test_survey_benchmark_smoke(capsys):
    argv = ["--runs", "1", "--rows", "1", "--cols", "2", "--time-scale", "8", "--json"]
    assert survey.main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    for cond in out:
        (run,) = cond["runs"]
        assert run["wall_s"] > run["lower_bound_s"] > 0 and run["ratio"] > 1.0
    assert out[1]["watched"] and out[1]["frames_received"] >= 0


@pytest.mark.timeout(120)
def test_bus_benchmark_smoke(capsys):
    assert bus.main(["--seconds", "1", "--commands", "3", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["subscribers"] for r in rows] == [0, 1, 16]
    assert rows[2]["fps_per_subscriber"] > 5 and rows[2]["frames"]["median_ms"] > 0


@pytest.mark.timeout(180)
@pytest.mark.skipif(bool(browser.MISSING), reason=browser.MISSING or "")
def test_operator_benchmark_smoke(capsys):
    assert operator.main(["--seconds", "1", "--clicks", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["frames"]["page_fps"] > 5 and out["frames"]["page"]["median_ms"] > 0
    assert out["click_to_motion"]["page"]["median_ms"] > 0
