"""Ground truth and scores of one scene's points, for ``bench.quality`` (whose docstring
defines the scores)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import cv2
import numpy as np

from cyborg.daemon.sim.scene import Scene
from cyborg.daemon.vision.interest import InterestPoint

REFERENCE_SHAPE = (216, 288)
"""The mosaic size on which ``--tolerance`` is given."""


def scaled_tolerance(shape: tuple[int, int], tolerance: float) -> float:
    """``tolerance`` (given for 216x288) scaled with the image diagonal.

    >>> round(scaled_tolerance((108, 192), 6.0), 2), scaled_tolerance((216, 288), 6.0)
    (3.67, 6.0)
    """
    return tolerance * math.hypot(*shape) / math.hypot(*REFERENCE_SHAPE)


def near_targets(scene: Scene, tolerance: float) -> np.ndarray:
    """uint8 mask of pixels within ``tolerance`` of a target (computed once per scene)."""
    size = 2 * round(tolerance) + 1
    return cv2.dilate(
        (scene.target_labels > 0).astype(np.uint8),
        cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size)),
    )


@dataclass(frozen=True)
class Truth:
    """One scene's ground truth, computed once and shared by every method and point."""

    near_target: np.ndarray
    """(M, N) uint8: within the tolerance of a target."""
    shadow: np.ndarray
    """(M, N) bool: decoy pixels."""
    objects: tuple[np.ndarray, ...]
    """(K, 2) row, column pixels of each target, then of each connected decoy component."""
    n_targets: int
    tolerance: float

    def owner(self, row: int, col: int, hit: bool) -> int | None:
        """Index of the object a point at (row, col) is assigned to (see distinct@3)."""
        n = self.n_targets
        candidates = range(n) if hit else range(n, len(self.objects))
        best, best_d = None, math.inf
        for k in candidates:
            px = self.objects[k]
            d = float(np.sqrt(((px - (row, col)) ** 2).sum(axis=1).min()))
            if d < best_d:
                best, best_d = k, d
        return best if hit or best_d <= self.tolerance else None


def truth(scene: Scene, tolerance: float) -> Truth:
    """Ground truth of ``scene`` at a hit tolerance already scaled to its size."""
    n = len(scene.targets)
    count, components = cv2.connectedComponents(scene.shadow_mask.astype(np.uint8), None, 8)
    objects = [np.argwhere(scene.target_labels == i) for i in range(1, n + 1)]
    objects += [np.argwhere(components == k) for k in range(1, count)]
    return Truth(near_targets(scene, tolerance), scene.shadow_mask, tuple(objects), n, tolerance)


def score_scene(truth: Truth, points: list[InterestPoint]) -> dict[str, float]:
    """Scores of one scene's points (``bench.quality``'s docstring defines them)."""
    rows, cols = truth.near_target.shape
    hits, decoys, owners = [], [], []
    for p in points[:3]:
        r = min(rows - 1, max(0, round(p.y)))
        c = min(cols - 1, max(0, round(p.x)))
        hits.append(bool(truth.near_target[r, c]))
        decoys.append(bool(truth.shadow[r, c]) and not hits[-1])
        owners.append(truth.owner(r, c, hits[-1]))
    owned = [o for o in owners if o is not None]
    return {
        "top1": float(bool(hits) and hits[0]),
        "any3": float(any(hits)),
        "precision3": sum(hits) / 3.0,
        "shadow3": sum(decoys) / 3.0,
        "decoy1": float(bool(decoys) and decoys[0]),
        "distinct3": float(len(owned) == len(set(owned))),
    }


def second_looks(scene: Scene, sigma: float = 2.0) -> tuple[Scene, Scene]:
    """The same outcrop seen twice more: fresh sensor noise on each look, drawn from the
    scene's seed so every method sees the same two looks."""
    rng = np.random.default_rng([scene.seed, 2])
    looks = []
    for _ in range(2):
        noisy = scene.image + rng.normal(0.0, sigma, scene.image.shape)
        looks.append(dataclasses.replace(scene, image=np.clip(noisy, 0, 255).astype(np.uint8)))
    return looks[0], looks[1]
