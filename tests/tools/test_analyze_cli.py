"""``cyborgd analyze`` as a real process: products, the --json contract, every error path."""

from __future__ import annotations

import json
import struct
import subprocess
import sys
import tracemalloc
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest

from cyborg.daemon.sim.scene import outcrop_scene
from cyborg.daemon.vision.job import analyze_image
from cyborg.daemon.vision.params import DEFAULT

PRODUCTS = [
    *(
        f"{kind}_{p}.png"
        for kind in ("plane", "segmentation", "cooccurrence", "uncommon")
        for p in "hsi"
    ),
    "interest.png",
    "overlay.png",
    "result.json",
]


def cyborgd(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "cyborg.daemon", *args],
        capture_output=True,
        text=True,
        check=False,
        cwd=cwd,
        timeout=120,
        env={"PYTHONPATH": str(Path(__file__).resolve().parents[2]), "PATH": "/usr/bin:/bin"},
    )


@pytest.fixture
def scene_png(tmp_path: Path) -> tuple[Path, object]:
    scene = outcrop_scene(5, n_targets=1)
    path = tmp_path / "outcrop.png"
    cv2.imwrite(str(path), scene.image)
    return path, scene


def test_products_and_result_json(tmp_path, scene_png):
    path, _ = scene_png
    out = tmp_path / "out"
    proc = cyborgd(
        "analyze", str(path), "--out", str(out), "--profile", "paper", "--top", "2", cwd=tmp_path
    )
    assert proc.returncode == 0, proc.stderr
    folder = out / "outcrop"
    for name in PRODUCTS:
        assert (folder / name).stat().st_size > 0, name
    doc = json.loads((folder / "result.json").read_text())
    assert doc["width"] == 288 and doc["height"] == 216 and doc["profile"] == "paper"
    assert doc["params"]["blur"] == 10.0 and doc["params"]["top_n"] == 2
    assert len(doc["points"]) == 2
    for p in doc["points"]:
        assert {"rank", "x", "y", "radius", "score", "description", "summary"} <= set(p)
        assert p["explanation"] and p["description"].endswith("% of the area")
        assert 0 <= p["x"] < 288 and 0 <= p["y"] < 216
    assert set(doc["classes"]) == {"H", "S", "I"}
    assert doc["timing_ms"]["total"] > 0
    overlay = cv2.imread(str(folder / "overlay.png"))
    assert overlay.shape == (216, 288, 3)
    assert not list(folder.glob(".*")), "temporary files left behind"


def test_json_lines_contract_and_downsample(tmp_path, scene_png):
    path, scene = scene_png
    big = cv2.resize(cv2.imread(str(path)), None, fx=4, fy=4, interpolation=cv2.INTER_NEAREST)
    big_path = tmp_path / "big.png"
    cv2.imwrite(str(big_path), big)
    proc = cyborgd(
        "analyze",
        str(big_path),
        "--downsample",
        "4",
        "--json",
        "--out",
        str(tmp_path / "o"),
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.strip().splitlines()
    assert len(lines) == 1
    doc = json.loads(lines[0])
    assert list(doc) == ["image", "width", "height", "points", "timing_ms"]
    assert doc["image"] == str(big_path) and (doc["width"], doc["height"]) == (1152, 864)
    assert [p["rank"] for p in doc["points"]] == [1, 2, 3]
    assert all(list(p) == ["rank", "x", "y", "score"] for p in doc["points"])
    target = scene.targets[0]
    best = min(
        np.hypot(p["x"] - (4 * target.x + 1.5), p["y"] - (4 * target.y + 1.5))
        for p in doc["points"]
    )
    assert best < 4 * (target.radius + 6), "points must come back in input-image pixels"


def test_a_12_mp_photo_needs_no_flags(tmp_path):
    """A 4000x3000 photo with three planted targets: analysed at the profile's working size
    with no flag, three distinct points in photo pixels, a small overlay PNG beside a
    full-size JPEG."""
    rng = np.random.default_rng(3)
    small = outcrop_scene(21, n_targets=0, shadows=False).image
    photo = cv2.resize(small, (4000, 3000), interpolation=cv2.INTER_CUBIC)
    photo = np.clip(photo + rng.normal(0, 4, photo.shape), 0, 255).astype(np.uint8)
    spots = {(900, 700): (40, 150, 60), (2900, 1100): (30, 40, 190), (2000, 2400): (235,) * 3}
    for (x, y), colour in spots.items():
        cv2.circle(photo, (x, y), 70, colour, -1)
    path = tmp_path / "photo.png"
    cv2.imwrite(str(path), photo)
    proc = cyborgd("analyze", str(path), "--out", str(tmp_path / "o"), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    folder = tmp_path / "o" / "photo"
    doc = json.loads((folder / "result.json").read_text())
    assert (doc["width"], doc["height"]) == (4000, 3000)
    assert doc["analysed"]["width"] * doc["analysed"]["height"] <= doc["params"]["max_pixels"]
    found = {
        min(spots, key=lambda s: np.hypot(p["x"] - s[0], p["y"] - s[1])): p for p in doc["points"]
    }
    assert len(found) == 3
    for (x, y), p in found.items():
        assert np.hypot(p["x"] - x, p["y"] - y) < 80
    assert (folder / "overlay.png").stat().st_size < 2_000_000
    assert cv2.imread(str(folder / "overlay_full.jpg")).shape == (3000, 4000, 3)


def test_12_mp_analysis_stays_within_the_memory_bound():
    photo = np.random.default_rng(1).integers(0, 256, (3000, 4000, 3), dtype=np.uint8)
    tracemalloc.start()
    analyze_image(photo, DEFAULT)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 1 << 30


def _png_header_only(width: int, height: int) -> bytes:
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    chunk = b"IHDR" + ihdr
    return (
        b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + chunk + struct.pack(">I", zlib.crc32(chunk))
    )


def test_bad_files_get_one_line_each_and_the_rest_go_on(tmp_path, scene_png):
    good, _ = scene_png
    (tmp_path / "empty.png").write_bytes(b"")
    (tmp_path / "text.png").write_text("not an image\n")
    (tmp_path / "bomb.png").write_bytes(_png_header_only(100_000, 100_000))
    (tmp_path / "truncated.png").write_bytes(good.read_bytes()[:100])
    (tmp_path / "folder.png").mkdir()
    jpeg = bytearray(cv2.imencode(".jpg", cv2.imread(str(good)))[1].tobytes())
    (tmp_path / "cut.jpg").write_bytes(jpeg[: len(jpeg) // 2])
    jpeg[len(jpeg) // 2 : len(jpeg) // 2 + 8] = bytes(b ^ 0xFF for b in jpeg[len(jpeg) // 2 :][:8])
    (tmp_path / "flipped.jpg").write_bytes(jpeg)
    bad = ["missing.png", "empty.png", "text.png", "bomb.png", "truncated.png", "folder.png"]
    bad += ["cut.jpg", "flipped.jpg"]
    proc = cyborgd("analyze", *bad, str(good), "--json", "--out", str(tmp_path / "o"), cwd=tmp_path)
    assert proc.returncode == 1
    errors = proc.stderr.strip().splitlines()
    assert len(errors) == len(bad), proc.stderr
    for name, line in zip(bad, errors, strict=True):
        assert line.startswith(f"cyborgd analyze: {name}: "), line
        assert "Traceback" not in line
    assert "too large" in errors[3]
    assert "truncated PNG" in errors[4] and "truncated JPEG" in errors[6]
    assert "corrupt image data: Corrupt JPEG data" in errors[7]  # libjpeg's line, attributed
    assert json.loads(proc.stdout)["image"] == str(good)


def test_unwritable_output_is_reported_and_exit_nonzero(tmp_path, scene_png):
    good, _ = scene_png
    blocker = tmp_path / "out"
    blocker.write_text("a file where the output folder should be")
    proc = cyborgd("analyze", str(good), "--out", str(blocker), cwd=tmp_path)
    assert proc.returncode == 1
    assert "cannot write products" in proc.stderr and "Traceback" not in proc.stderr


def test_grey_16bit_rgba_and_tiny_files(tmp_path):
    rng = np.random.default_rng(1)
    files = {
        "grey16.png": rng.integers(0, 65536, (40, 50), dtype=np.uint16),
        "rgba.png": rng.integers(0, 256, (40, 50, 4), dtype=np.uint8),
        "one.png": np.zeros((1, 1, 3), np.uint8),
        "flat.png": np.full((30, 30), 100, np.uint8),
    }
    for name, img in files.items():
        cv2.imwrite(str(tmp_path / name), img)
    proc = cyborgd("analyze", *files, "--json", "--out", str(tmp_path / "o"), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    docs = [json.loads(line) for line in proc.stdout.splitlines()]
    assert [d["image"] for d in docs] == list(files)
    assert docs[2]["points"] == [] and docs[3]["points"] == []


def test_set_changes_one_parameter_and_result_json_records_it(tmp_path, scene_png):
    path, _ = scene_png
    out = tmp_path / "out"
    proc = cyborgd(
        "analyze",
        str(path),
        "--out",
        str(out),
        "--profile",
        "paper",
        "--set",
        "uncommon=surprisal",
        "--set",
        "blur=8",
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((out / "outcrop" / "result.json").read_text())
    assert doc["profile"] == "paper"
    assert (doc["params"]["uncommon"], doc["params"]["blur"]) == ("surprisal", 8.0)
    assert doc["params"]["max_classes"] == 8 and doc["points"]


def test_usage_errors(tmp_path):
    bad = cyborgd("analyze", "x.png", "--set", "blurr=3", cwd=tmp_path)
    assert bad.returncode == 2 and "unknown parameter 'blurr' (did you mean blur?)" in bad.stderr
    bad = cyborgd("analyze", "x.png", "--set", "wide_scale=0.5", cwd=tmp_path)
    assert bad.returncode == 2 and "wide_scale must be 0 or above 1" in bad.stderr
    assert cyborgd("analyze", "x.png", "--profile", "nope", cwd=tmp_path).returncode == 2
    assert cyborgd("analyze", "x.png", "--downsample", "0", cwd=tmp_path).returncode == 2
    bad = cyborgd("analyze", "x.png", "--top", "0", cwd=tmp_path)
    assert bad.returncode == 2 and "--top must be at least 1" in bad.stderr
    assert cyborgd("analyze", cwd=tmp_path).returncode == 2
