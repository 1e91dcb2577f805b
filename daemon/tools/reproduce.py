"""``make demo`` until the daemon exists: analyse a generated outcrop with both profiles."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np

from ..sim.regimes import seed_cliff
from ..sim.scene import outcrop_scene
from ..vision.imageio import write_atomic, write_png
from ..vision.params import PROFILES
from .analyze import AnalyzeOptions, analyze_files

SHEET = (
    "overlay",
    "interest",
    "segmentation_h",
    "segmentation_s",
    "segmentation_i",
    "cooccurrence_i",
)
"""A contact sheet of one analysis, three products a row."""
REPRODUCTION = (
    *("plane_i", "segmentation_h", "segmentation_s", "segmentation_i"),
    *("overlay", "uncommon_h", "uncommon_s", "uncommon_i"),
    *("interest", "cooccurrence_h", "cooccurrence_s", "cooccurrence_i"),
)
"""The seed papers' Figs. 4, 5 and 7 as one sheet: the mosaic, its three segmentations, the
uncommon maps, the interest map and the points, four products a row."""


def _sheet(folder: Path, names: tuple[str, ...], per_row: int, zoom: int = 1) -> np.ndarray:
    """Products of one analysis side by side, each labelled, at the first one's size."""
    tiles = [cv2.imread(str(folder / f"{n}.png"), cv2.IMREAD_COLOR) for n in names]
    h, w = tiles[0].shape[0] * zoom, tiles[0].shape[1] * zoom
    tiles = [cv2.resize(t, (w, h), interpolation=cv2.INTER_NEAREST) for t in tiles]
    for t, n in zip(tiles, names, strict=True):
        cv2.putText(t, n, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 3, cv2.LINE_AA)
        cv2.putText(t, n, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1, cv2.LINE_AA)
    rows = [np.hstack(tiles[i : i + per_row]) for i in range(0, len(tiles), per_row)]
    return np.vstack(rows)


def _seed_case(out: Path, seed: int) -> int:
    """The seed's own case (a pale cliff, two wet stains) through the faithful profile."""
    scene = seed_cliff(seed, shadow=False)
    path = out / "seed-case.png"
    write_png(path, scene.image)
    folder = out / "seed-case"
    status = analyze_files([str(path)], AnalyzeOptions(folder, "paper", PROFILES["paper"]))
    write_png(
        folder / "seed-case" / "reproduction.png", _sheet(folder / "seed-case", REPRODUCTION, 4, 2)
    )
    labels = cv2.dilate(scene.target_labels, np.ones((7, 7), np.uint8))
    points = json.loads((folder / "seed-case" / "result.json").read_text())["points"]
    stains = sum(bool(labels[round(p["y"]), round(p["x"])]) for p in points[:2])
    print(
        f"seed case (paper profile): {stains} of 2 wet stains in the top two points; "
        f"reproduction sheet {folder / 'seed-case' / 'reproduction.png'}"
    )
    return status


def reproduce(out: Path, seed: int) -> int:
    scene = outcrop_scene(seed, n_targets=3)
    scene_path = out / "scene.png"
    write_png(scene_path, scene.image)
    truth = [{"kind": t.kind, "x": round(t.x, 1), "y": round(t.y, 1)} for t in scene.targets]
    write_atomic(out / "targets.json", (json.dumps(truth, indent=2) + "\n").encode())
    print(f"scene: {scene_path} (planted: {', '.join(t['kind'] for t in truth)})")
    status = 0
    for name, params in PROFILES.items():
        opts = AnalyzeOptions(out / name, name, params)
        status |= analyze_files([str(scene_path)], opts)
        folder = out / name / "scene"
        write_png(folder / "sheet.png", _sheet(folder, SHEET, 3))
        points = json.loads((folder / "result.json").read_text())["points"]
        print(f"  {name:8s} products in {folder}/ (overlay.png, sheet.png, result.json, ...)")
        for p in points:
            near = min(scene.targets, key=lambda t, p=p: np.hypot(t.x - p["x"], t.y - p["y"]))
            dist = float(np.hypot(near.x - p["x"], near.y - p["y"]))
            found = f"found the {near.kind}" if dist <= near.radius + 6 else "no planted target"
            print(f"    #{p['rank']} ({p['x']:.0f}, {p['y']:.0f}): {found}; {p['description']}")
    return status | _seed_case(out, seed)
