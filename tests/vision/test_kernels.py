"""The fast paths compute what their plain definition says: the compiled shadow kernel (A/B
against a reference written out in numpy, float64, on random colours and on an outcrop's),
the flood that finds a peak's patch and the queue that orders the peaks."""

from __future__ import annotations

import heapq
import os
import subprocess
import sys

import cv2
import numpy as np
import pytest

from cyborg.daemon.sim.scene import outcrop_scene
from cyborg.daemon.vision import peaks, shadow
from cyborg.daemon.vision.params import DEFAULT


def _evidence(own: np.ndarray, host: np.ndarray, u: tuple[float, float]) -> tuple:
    """Tinted and untinted shadow evidence of each pixel against the host beside it, as
    ``shadow``'s docstring defines them, whole arrays at a time."""

    def project(logs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        db, dg = logs[..., 0] - logs[..., 2], logs[..., 1] - logs[..., 2]
        return -logs.mean(-1) / shadow._DARK, db * u[0] + dg * u[1], dg * u[0] - db * u[1]

    lin_own, lin_host = np.exp(own) - shadow._OFFSET, np.exp(host) - shadow._OFFSET
    darker = np.clip(lin_own.mean(-1) / (lin_host.mean(-1) + 1e-3), 0.0, 1.0)
    darkened = np.log(lin_host * darker[..., None] + shadow._OFFSET)
    (dark_own, along_own, across_own), dark_host = project(own), project(host)[0]
    _, along_ref, across_ref = project(darkened)
    darkness, along = dark_own - dark_host, along_own - along_ref
    cone = np.abs(along) * shadow._CONE[1] + shadow._CONE[0]
    purity = 1.0 - np.abs(across_own - across_ref) / cone
    dark = np.clip(darkness, 0, 1) * np.clip(purity, 0, 1)
    coloured = np.clip((host.max(-1) - host.min(-1)) / shadow._HOST_CHROMA - 1.0, 0, 1)
    low, high = shadow._UNTINTED
    tinted = dark * np.clip(along / shadow._TINT, 0, 1)
    untinted = dark * np.clip((along + high) / (high - low), 0, 1) * coloured
    return tinted, untinted, darkness


def reference_shade(own: np.ndarray, host: np.ndarray, u: tuple, d: int) -> tuple:
    own, host = own.astype(np.float64), host.astype(np.float64)
    rows, cols = own.shape[:2]
    tinted, untinted, darkness = _evidence(own, host, u)
    candidate = darkness > shadow._CANDIDATE
    ys, xs = np.mgrid[:rows, :cols]
    for dy, dx in ((0, d), (0, -d), (d, 0), (-d, 0)):
        side = host[np.clip(ys - dy, 0, rows - 1), np.clip(xs - dx, 0, cols - 1)]
        t, v, _ = _evidence(own, side, u)
        tinted = np.where(candidate, np.maximum(tinted, t), tinted)
        untinted = np.where(candidate, np.maximum(untinted, v), untinted)
    return tinted, untinted


def _log_colours(bgr: np.ndarray) -> np.ndarray:
    return np.log(bgr.astype(np.float32) + np.float32(shadow._OFFSET))


def _cases() -> list[tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(4)
    random = _log_colours(rng.integers(0, 256, (37, 53, 3)))
    scene = outcrop_scene(3, (90, 120)).image
    own = _log_colours(scene)
    host = cv2.GaussianBlur(own, (0, 0), 6.0)  # its surroundings, the lit and the shaded
    return [(random, _log_colours(rng.integers(0, 256, (37, 53, 3)))), (own, host)]


@pytest.mark.parametrize("case", [0, 1], ids=["random", "outcrop"])
@pytest.mark.parametrize("d", [1, 7])
def test_the_shade_kernel_equals_its_definition(case: int, d: int) -> None:
    own, host = _cases()[case]
    u = tuple(np.array(DEFAULT.shadow_tint) / np.hypot(*DEFAULT.shadow_tint))
    fast = shadow._shade(own, host, DEFAULT.shadow_tint, d)
    slow = reference_shade(own, host, u, d)
    for a, b in zip(fast, slow, strict=True):
        assert a.dtype == np.float32 and a.shape == own.shape[:2]
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-5)  # float32 rounding
    assert (slow[0] > 0.5).any() and (slow[1] > 0.5).any()  # both kinds of evidence occur


def test_compiled_kernels_are_kept_in_the_services_cache_directory(tmp_path) -> None:
    """Under systemd (``CacheDirectory=cyborgd``) the kernels are compiled once into
    $CACHE_DIRECTORY; a folder that cannot be written is passed over, not a crash."""
    blocked = tmp_path / "a-file"  # no folder can be made in it, even by root
    blocked.write_text("")
    cache = tmp_path / "cache"
    probe = "from cyborg.daemon.vision import kernels; kernels.warm(); print(kernels.cache_dir())"
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env["CACHE_DIRECTORY"] = f"{blocked / 'cyborgd'}:{cache}"
    out = subprocess.run(
        [sys.executable, "-c", probe], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == str(cache / "numba")
    assert list((cache / "numba").rglob("*.nbi")), "no compiled kernel was cached"


def test_a_patch_is_the_connected_part_of_the_map_holding_the_peak() -> None:
    """``peaks._patch`` floods from the peak; the definition labels the whole map."""
    rng = np.random.default_rng(1)
    for _ in range(300):
        noise = rng.normal(size=(rng.integers(3, 40), rng.integers(3, 40))).astype(np.float32)
        grid = cv2.GaussianBlur(noise, (0, 0), rng.uniform(0.5, 3.0))
        r, c = rng.integers(grid.shape[0]), rng.integers(grid.shape[1])
        level = float(np.quantile(grid, rng.uniform()))
        _, labels = cv2.connectedComponents((grid >= level).astype(np.uint8), connectivity=8)
        np.testing.assert_array_equal(peaks._patch(grid, r, c, level), labels == labels[r, c])


def test_peaks_come_highest_first_as_one_heap_of_them_all_would_give_them() -> None:
    """``peaks._Queue`` (one sort, a heap for the discounted) against a heap of every peak,
    with ties and discounted peaks pushed back as they come up."""
    rng = np.random.default_rng(2)
    for _ in range(50):
        n = int(rng.integers(1, 60))
        heights = rng.integers(0, 6, n).astype(np.float32)  # many ties
        rows, cols = np.divmod(rng.permutation(400)[:n], 20)
        order = np.lexsort((cols, rows))  # as np.nonzero lists them
        heights, rows, cols = heights[order], rows[order], cols[order]
        share = rng.uniform(0.2, 1.0, n)
        heap = [
            (-float(h), int(r), int(c), False) for h, r, c in zip(heights, rows, cols, strict=True)
        ]
        heapq.heapify(heap)
        queue = peaks._Queue(heights, rows, cols, final=False)
        while heap:
            want = heapq.heappop(heap)
            assert queue.pop() == want
            if not want[3]:
                k = int(np.flatnonzero((rows == want[1]) & (cols == want[2]))[0])
                heapq.heappush(heap, (want[0] * share[k], want[1], want[2], True))
                queue.push(want[0] * share[k], want[1], want[2])
        assert queue.pop() is None
