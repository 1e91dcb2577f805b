"""``make demo`` until the daemon exists: analyse a generated outcrop with both profiles."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np

from .analyze import AnalyzeOptions, analyze_files
from .imageio import write_atomic, write_png
from .scene import outcrop_scene
from .vision.params import PROFILES


def _sheet(folder: Path) -> np.ndarray:
    """A contact sheet: overlay, interest map, the three segmentations, the I co-occurrence."""
    names = [
        "overlay",
        "interest",
        "segmentation_h",
        "segmentation_s",
        "segmentation_i",
        "cooccurrence_i",
    ]
    tiles = [cv2.imread(str(folder / f"{n}.png"), cv2.IMREAD_COLOR) for n in names]
    h, w = tiles[0].shape[:2]
    tiles = [cv2.resize(t, (w, h), interpolation=cv2.INTER_NEAREST) for t in tiles]
    for t, n in zip(tiles, names, strict=True):
        cv2.putText(t, n, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 3, cv2.LINE_AA)
        cv2.putText(t, n, (4, 14), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (255, 255, 255), 1, cv2.LINE_AA)
    return np.vstack([np.hstack(tiles[:3]), np.hstack(tiles[3:])])


def run_demo(out: Path, seed: int) -> int:
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
        write_png(folder / "sheet.png", _sheet(folder))
        points = json.loads((folder / "result.json").read_text())["points"]
        print(f"  {name:8s} products in {folder}/ (overlay.png, sheet.png, result.json, ...)")
        for p in points:
            near = min(scene.targets, key=lambda t, p=p: np.hypot(t.x - p["x"], t.y - p["y"]))
            dist = float(np.hypot(near.x - p["x"], near.y - p["y"]))
            found = f"found the {near.kind}" if dist <= near.radius + 6 else "no planted target"
            print(f"    #{p['rank']} ({p['x']:.0f}, {p['y']:.0f}): {found}; {p['description']}")
    return status
