"""Smoke tests: the demo writes its products; the benchmarks run on a few inputs."""

from __future__ import annotations

import json
import math
import re
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from bench import (
    ab,
    approach,
    browser,
    bus,
    heldout,
    operator,
    ptu,
    quality,
    real,
    security,
    speed,
    survey,
)
from bench.stats import repeats
from cyborg.daemon.sim.regimes import seed_cliff
from cyborg.daemon.sim.scene import Scene, Target, outcrop_scene
from cyborg.daemon.tools.reproduce import reproduce
from cyborg.daemon.vision.interest import InterestPoint


def test_demo_writes_everything(tmp_path, capsys):
    assert reproduce(tmp_path, seed=7) == 0
    out = capsys.readouterr().out
    for profile in ("default", "paper"):
        folder = tmp_path / profile / "scene"
        assert (folder / "sheet.png").exists() and (folder / "overlay.png").exists()
        assert json.loads((folder / "result.json").read_text())["profile"] == profile
        assert str(folder) in out
    assert len(json.loads((tmp_path / "targets.json").read_text())) == 3


def test_quality_benchmark_smoke():
    results = quality.run(n_scenes=2, seed=0, tolerance=6.0)
    assert list(results) == ["tiny", "seed", "large", "veins", "empty"]
    for table in results.values():
        assert set(table) == {
            "default",
            "paper",
            "uncommon",
            "spectral-residual",
            "colour-rarity",
            "rx-anomaly",
            "random",
        }
        for row in table.values():
            for key in ("top1", "any3", "precision3", "shadow3", "decoy1", "distinct3", "repeat1"):
                assert 0.0 <= row[key] <= 1.0
    # Nothing to hit in an empty scene.
    assert all(row["any3"] == 0.0 for row in results["empty"].values())


def test_quality_cli_runs_chosen_regimes_and_prints_a_verdict_each(capsys):
    assert quality.main(["--regimes", "seed,empty", "--scenes", "1", "--json"]) == 0
    assert list(json.loads(capsys.readouterr().out)) == ["seed", "empty"]
    assert quality.main(["--regimes", "seed,empty", "--scenes", "1", "--cliffs", "2"]) == 0
    out = capsys.readouterr().out
    assert "108x192, tolerance 3.7 px" in out and "paper, seed case, 2 cliffs" in out
    assert [line.split()[0] for line in out.splitlines()[-2:]] == ["seed", "empty"]
    # One scene says little, and the verdict's 95 % interval says so.
    assert re.search(r"repeat@1 (100\.0% \[21-100\]|0\.0% \[0-79\]) (ok|NO);", out)
    assert re.search(r"both stains top two \d+ % \[\d+-\d+\]", out)
    with pytest.raises(SystemExit):
        quality.main(["--regimes", "nope", "--scenes", "1"])


def test_quality_settings_change_every_pipeline_profile_and_no_baseline(capsys):
    scene = seed_cliff(3)
    table = quality.methods(["top_n=1"])
    rng = np.random.default_rng(0)
    assert [len(table[m](scene, rng)) for m in ("default", "paper", "uncommon")] == [1, 1, 1]
    assert len(table["rx-anomaly"](scene, rng)) == 3
    args = ["--regimes", "seed", "--scenes", "1", "--cliffs", "1", "--set", "uncommon=surprisal"]
    assert quality.main(args) == 0
    assert "settings, in every pipeline profile: uncommon=surprisal" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        quality.main(["--regimes", "seed", "--scenes", "1", "--set", "blurr=3"])
    assert "unknown parameter 'blurr' (did you mean blur?)" in capsys.readouterr().err


def test_quality_cli_scores_the_held_out_generator_and_its_seed_case(capsys):
    args = ["--heldout", "--regimes", "empty,seed", "--scenes", "1", "--cliffs", "2"]
    assert quality.main(args) == 0
    out = capsys.readouterr().out
    assert "held-out generator (bench.heldout): reported, never tuned on" in out
    assert "empty: held out: rock and ledge shadows, no target; 216x288" in out
    assert "seed: held out: the seed's pale cliff" in out and "108x192" in out
    assert "paper, seed case, 2 cliffs: both stains top two" in out
    assert [line.split()[0] for line in out.splitlines()[-2:]] == ["empty", "seed"]
    lines = [line for line in out.splitlines() if line.startswith("paper, seed case")]
    ours = quality.seed_case(2, 0)["seed_case"]
    held = quality.seed_case(2, 0, cliff=heldout.seed_cliff)["seed_case"]
    assert lines[0].startswith(
        f"paper, seed case, 2 cliffs: both stains top two {100 * held['stains_top2']:.0f} %"
    )
    assert set(ours) == set(held)
    ours = quality.run(1, 3, 6.0, ["empty"])["empty"]["default"]
    held = quality.run(1, 3, 6.0, ["empty"], generators=heldout.REGIMES)["empty"]["default"]
    assert set(ours) == set(held)


def test_quality_cli_through_a_camera_says_so_and_scores_the_same_way(capsys):
    assert quality.main(["--regimes", "tiny", "--scenes", "2", "--cliffs", "0", "--camera"]) == 0
    out = capsys.readouterr().out
    assert "through a camera: vignetting, gradient, defocus, jpeg (JPEG quality 60-90" in out
    assert out.splitlines()[-1].startswith("tiny   default:")
    assert (
        quality.main(["--regimes", "empty", "--scenes", "1", "--cliffs", "0", "--camera", "jpeg"])
        == 0
    )
    assert "through a camera: jpeg (" in capsys.readouterr().out
    args = ["--regimes", "empty", "--scenes", "1", "--cliffs", "0", "--camera", "jpeg"]
    assert quality.main([*args, "--camera-scale", "2"]) == 0
    assert "frame 2x the analysed size" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        quality.main(["--regimes", "empty", "--scenes", "1", "--camera-scale", "2"])
    assert "--camera-scale needs --camera" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        quality.main(["--regimes", "empty", "--scenes", "1", "--camera", "--camera-scale", "0.5"])
    assert "a camera's scale is >= 1" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        quality.main(["--regimes", "empty", "--scenes", "1", "--camera", "fisheye"])
    assert "unknown camera effects ['fisheye']" in capsys.readouterr().err
    clean = quality.run(n_scenes=2, seed=0, tolerance=6.0, regimes=["tiny"])["tiny"]
    seen = quality.run(2, 0, 6.0, ["tiny"], camera=("defocus", "jpeg"))["tiny"]
    assert set(seen) == set(clean)
    # The random baseline ignores the image: the camera cannot move its points.
    assert seen["random"]["top1"] == clean["random"]["top1"]


def test_quality_distinct3_counts_objects_hit_twice_not_points():
    labels = np.zeros((60, 80), np.uint8)
    labels[10:14, 10:14] = 1
    labels[40:44, 60:64] = 2
    shadow = np.zeros((60, 80), bool)
    shadow[30:34, 5:45] = True  # one decoy component, 40 px long
    targets = (Target("red_spot", 11.5, 11.5, 2.0), Target("plant", 61.5, 41.5, 2.0))
    gt = quality.truth(Scene(np.zeros((60, 80, 3), np.uint8), targets, labels, shadow, 0), 6.0)

    def score(*xy):
        points = [InterestPoint(i + 1, x, y, 1.0) for i, (x, y) in enumerate(xy)]
        return quality.score_scene(gt, points)

    # Two targets and the shadow: three objects.
    assert score((12, 12), (61, 41), (20, 32))["distinct3"] == 1.0
    # Two points on target 1 (one of them 5 px off its edge, still a hit).
    both = score((12, 12), (18, 12), (61, 41))
    assert both["distinct3"] == 0.0 and both["precision3"] == 1.0
    # Two points along one shadow, 30 px apart; the first is a decoy@1.
    decoyed = score((8, 32), (38, 32), (12, 12))
    assert decoyed["distinct3"] == 0.0 and decoyed["decoy1"] == 1.0
    assert decoyed["shadow3"] == pytest.approx(2 / 3)
    # Misses never collide, and a point near the shadow but off it is assigned to it.
    assert score((70, 5), (72, 8), (20, 37))["distinct3"] == 1.0
    assert score((20, 37), (22, 31), (70, 5))["distinct3"] == 0.0


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
    assert repeats([here], [InterestPoint(1, 13.0, 14.0, 0.5), there], 6.0)
    assert not repeats([here], [there, here], 6.0)
    assert not repeats([], [here], 6.0)


def _toy_set(root, names=("a.png", "b.png")):
    """A one-set data folder: grey 100x100 images, a bright 5x5 target, its mask."""
    folder = root / "toy"
    for sub in ("images", "masks", "masks_part"):
        (folder / sub).mkdir(parents=True)
    rows = ["name\ttag\tmask_share"]
    for k, name in enumerate(names):
        image = np.full((100, 100), 100, np.uint8)
        mask = np.zeros((100, 100), np.uint8)
        r, c = 20 + 40 * k, 30
        image[r : r + 5, c : c + 5] = 220
        mask[r : r + 5, c : c + 5] = 255
        cv2.imwrite(str(folder / "images" / name), image)
        cv2.imwrite(str(folder / "masks" / name), mask)
        part = np.zeros_like(mask)
        part[99, 99] = 255  # a "target" in the far corner only
        cv2.imwrite(str(folder / "masks_part" / name), part)
        rows.append(f"{name}\t\t0.0025")
    (folder / "manifest.tsv").write_text("\n".join(rows) + "\n")
    return folder


def test_real_benchmark_hit_rule_on_a_synthetic_mask(tmp_path):
    folder = _toy_set(tmp_path)
    mask = cv2.imread(str(folder / "masks" / "a.png"), cv2.IMREAD_UNCHANGED)
    near = real.near_mask(mask)  # radius 1.5 % of the 141.4 px diagonal = 2.12 px
    pt = [InterestPoint(1, x, y, 1.0) for x, y in [(36.4, 22), (37, 22), (36, 26), (150, 120)]]
    # 2 px right of the target: hit; 3 px: miss; (2, 2) px diagonal = 2.83 px: miss.
    assert real.hits(near, pt) == [True, False, False]
    assert real.score(real.hits(near, pt)) == {"top1": 1.0, "any3": 1.0, "p3": 1 / 3}
    assert real.score(real.hits(near, pt[1:])) == {"top1": 0.0, "any3": 0.0, "p3": 0.0}
    # A missing point is a miss; a point outside the image is clipped onto its edge.
    assert real.score([True]) == {"top1": 1.0, "any3": 1.0, "p3": 1 / 3}
    corner = real.near_mask(cv2.imread(str(folder / "masks_part" / "a.png"), 0))
    assert real.hits(corner, pt[3:]) == [True]

    (folder / "manifest.tsv").write_text(
        (folder / "manifest.tsv").read_text() + "missing.png\t\t0.0\n"
    )
    results = real.run(tmp_path, methods=["colour-rarity", "random"])
    assert results["sets"] == ["toy"] and len(results["failed"]) == 1
    assert list(results["groups"]) == ["toy", "toy-part", "pooled"]
    toy = results["groups"]["toy"]
    assert toy["n"] == 2 and toy["chance"]["top1"] == pytest.approx(near.mean())
    assert toy["rates"]["colour-rarity"] | {"ms": 0} == {
        "top1": 1.0,
        "any3": 1.0,
        "p3": pytest.approx(1 / 3),
        "repeat1": 1.0,
        "ms": 0,
    }
    assert results["groups"]["toy-part"]["rates"]["colour-rarity"]["top1"] == 0.0
    # Same looks, same points: the run is deterministic.
    again = real.run(tmp_path, methods=["colour-rarity", "random"])
    for name in ("colour-rarity", "random"):
        first, second = toy["rates"][name], again["groups"]["toy"]["rates"][name]
        assert {k: v for k, v in first.items() if k != "ms"} == {
            k: v for k, v in second.items() if k != "ms"
        }


def test_real_benchmark_jpeg_looks_are_a_cameras_frames_and_bad_quality_is_refused(
    tmp_path, capsys
):
    folder = _toy_set(tmp_path)
    grey = cv2.imread(str(folder / "images" / "a.png"), cv2.IMREAD_UNCHANGED)
    plain, jpeg = real.looks(grey, 7), real.looks(grey, 7, 60)
    for a, b in zip(plain, jpeg, strict=True):
        # Same noise, then the JPEG: grey stays grey, close to the noisy look, not equal.
        assert b.shape == a.shape == grey.shape and b.dtype == np.uint8
        assert 0 < np.abs(b.astype(int) - a).mean() < 4
    assert all((x == y).all() for x, y in zip(jpeg, real.looks(grey, 7, 60), strict=True))
    results = real.run(tmp_path, methods=["colour-rarity"], jpeg=60)
    assert results["jpeg"] == 60 and results["groups"]["toy"]["rates"]["colour-rarity"]["top1"] == 1
    assert "repeat looks through JPEG quality 60" in real.format_table(results)[0]
    with pytest.raises(ValueError, match=r"1\.\.100, got 101"):
        real.run(tmp_path, methods=["colour-rarity"], jpeg=101)
    # Refused before the data are looked for, with the reason.
    with pytest.raises(SystemExit):
        real.main(["--data", str(tmp_path / "nowhere"), "--jpeg", "0"])
    assert "JPEG quality is 1..100, got 0" in capsys.readouterr().err


def test_real_benchmark_settings_reach_the_pipeline_profiles(tmp_path, capsys):
    _toy_set(tmp_path)
    # The toy target is 0.25 % of the image: under paper's class floor (0.5 % of the pairs),
    # so no class and no point; with the floor lowered, paper finds it.
    before = real.run(tmp_path, methods=["paper"])["groups"]["toy"]["rates"]["paper"]
    results = real.run(tmp_path, methods=["paper"], settings=["min_class_fraction=0.001"])
    assert results["settings"] == ["min_class_fraction=0.001"]
    assert before["top1"] == 0.0 and results["groups"]["toy"]["rates"]["paper"]["top1"] == 1.0
    header = real.format_table(results)[0]
    assert header.endswith("; in every pipeline profile min_class_fraction=0.001")
    # A mistyped setting is refused even where there is no data to score.
    with pytest.raises(SystemExit):
        real.main(["--data", str(tmp_path / "nowhere"), "--set", "top_n=two"])
    assert "top_n: cannot read 'two' as int" in capsys.readouterr().err


def test_real_benchmark_says_so_when_the_data_are_absent(tmp_path, capsys):
    assert real.main(["--data", str(tmp_path / "nowhere")]) == 0
    out = capsys.readouterr().out.strip()
    assert len(out.splitlines()) == 1 and "absent" in out


def test_real_benchmark_smoke_on_the_real_data():
    data = real.default_data_dir()
    if not (data / "crackforest").is_dir() or not (data / "ai4mars").is_dir():
        pytest.skip(f"real data absent at {data} (set CYBORG_REAL_DATA to run this)")
    results = real.run(data, sets=["crackforest", "ai4mars"], limit=2)
    assert list(results["groups"]) == ["crackforest", "ai4mars", "pooled"]
    assert results["groups"]["pooled"]["n"] == 4 and not results["failed"]
    for group in results["groups"].values():
        assert set(group["rates"]) == set(real.methods())
        for row in group["rates"].values():
            assert all(0.0 <= row[k] <= 1.0 for k in ("top1", "any3", "p3", "repeat1"))
    assert real.verdict(results) is not None
    verdict = [line for line in real.format_table(results) if line.startswith("verdict:")]
    assert len(verdict) == 1 and re.search(r"pooled repeat@1 [\d.]+% \[\d+-\d+\]", verdict[0])


def test_speed_benchmark_smoke():
    rows = speed.run(sizes={"tiny": (54, 96)}, repeats=1)
    assert rows[0]["name"] == "tiny" and rows[0]["ms"] > 0 and rows[0]["floor_ms"] > 0


def test_ab_benchmark_times_each_image_in_both_trees_in_turn(tmp_path, monkeypatch, capsys):
    """Two real analysis processes (here of one tree), the same images, one ratio per image."""
    monkeypatch.setenv("CYBORG_REAL_DATA", str(tmp_path))  # no real images: the cliffs only
    tree = Path(ab.__file__).resolve().parents[1]
    argv = ["--before", str(tree), "--python", sys.executable, "--seed-scenes", "2"]
    assert ab.main([*argv, "--repeats", "1"]) == 0
    out = capsys.readouterr().out
    assert "no real images" in out and "real images (" not in out
    pattern = r"the seed's 108x192 \(2\): before median [\d.]+ .* per image median [\d.]+"
    assert re.search(pattern, out)


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
    report = json.loads(capsys.readouterr().out)
    rows = report["subscribers"]
    assert [r["subscribers"] for r in rows] == [0, 1, 16]
    assert all(
        math.isfinite(v) for v in (rows[2]["fps_per_subscriber"], rows[2]["frames"]["median_ms"])
    )
    assert len(report["streams"]) == 5 and all(r["kbit_s"] >= 0 for r in report["streams"])


@pytest.mark.timeout(180)
@pytest.mark.skipif(bool(browser.MISSING), reason=browser.MISSING or "")
def test_operator_benchmark_smoke(capsys):
    assert operator.main(["--seconds", "1", "--clicks", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert all(
        math.isfinite(v) for v in (out["frames"]["page_fps"], out["frames"]["page"]["median_ms"])
    )
    assert out["click_to_motion"]["page"]["median_ms"] > 0


@pytest.mark.timeout(240)
def test_security_benchmark_smoke(capsys):
    """Nothing hostile executes, nothing crashes, and both frame paths are measured."""
    assert security.main(["--queries", "200", "--seconds", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for section in ("hostile queries", "strangers", "console"):
        c = out[section]
        assert c["tried"] > 0 and c["executed"] == 0 and c["refused"] == c["tried"], section
    assert out["crashed"] == 0 and not out["head moved"]
    assert set(out["frames"]) == {"plain tcp", "tls + acl"}


async def test_approach_benchmark_smoke(tmp_path):
    """One approach through the real survey engine on a procedural world: three stations,
    each registered to the one before, and the 10 m chips judged against the stain's core."""
    scores = await approach.approach(1000, "default", 0.5, tmp_path)
    assert scores["stations"] == 3
    assert isinstance(scores["core_in_chip"], bool) and scores["core_offset_frames"] >= 0
    assert len(scores["residual_deg"]) == 2 and all(r < 1.0 for r in scores["residual_deg"])
    summary = approach._summary([scores])
    assert summary["completed"] == 1 and 0.0 <= summary["core_in_chip"] <= 1.0


async def test_approach_first_station_smoke(tmp_path):
    """``--first-station``: one station per world and profile, scored on the 300 m choice
    only (no walk, no close-range scores)."""
    scores = await approach.approach(1000, "default", 0.0, tmp_path, legs=1)
    assert scores["stations"] == 1 and isinstance(scores["stain_300m"], bool)
    assert "core_in_chip" not in scores and scores["residual_deg"] == []


def test_approach_first_station_cli(capsys):
    assert approach.main(["--first-station", "1", "--json"]) == 0
    shares = json.loads(capsys.readouterr().out)
    assert set(shares) == set(approach.FIRST_STATION)
    assert all(v in (0.0, 1.0) for v in shares.values())
