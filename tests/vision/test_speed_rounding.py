"""Compiled kernels that sum in another order than the numpy calls they replace give the same
values up to that rounding: the peak picker's patch shape and frame share, its mean shift, and
texture's row norms. (The kernels that keep numpy's order are pinned bit for bit in
``test_speed_fused`` and ``test_exact_speed_paths``.)"""

from __future__ import annotations

import math

import numpy as np

from cyborg.daemon.vision import peaks, texture


def _patches() -> list[np.ndarray]:
    """Seeded masks: blobs, bands, slivers on the frame, single cells, and random speckle."""
    rng = np.random.default_rng(21)
    out = []
    for _ in range(60):
        rows, cols = (int(v) for v in rng.integers(3, 90, 2))
        yy, xx = np.mgrid[:rows, :cols]
        cy, cx = rng.uniform(-5, rows + 5), rng.uniform(-5, cols + 5)
        a, b, t = rng.uniform(0.5, 40), rng.uniform(0.5, 12), rng.uniform(0, math.pi)
        u, v = (yy - cy) * math.cos(t) + (xx - cx) * math.sin(t), (xx - cx) * math.cos(t)
        out.append((u / a) ** 2 + ((v - (yy - cy) * math.sin(t)) / b) ** 2 <= 1.0)
        out.append(rng.random((rows, cols)) < rng.uniform(0.001, 0.5))
    out.append(np.zeros((5, 5), bool))
    one = np.zeros((5, 5), bool)
    one[2, 3] = True
    return [*out, one]


def reference_band_discount(patch: np.ndarray, width: float) -> float:
    """The covariance's eigenvalues by ``np.cov`` and LAPACK."""
    ys, xs = np.nonzero(patch)
    if len(ys) < 3:
        return 1.0
    across, along = np.sqrt(np.maximum(np.linalg.eigvalsh(np.cov(np.stack([ys, xs]))), 0.0))
    if across <= width:
        return 1.0
    return min(1.0, float(across / along) / peaks._BAND_ASPECT)


def reference_frame_share(patch: np.ndarray, reach: float) -> float:
    ys, xs = np.nonzero(patch)
    if len(ys) == 0:
        return 0.0
    rows, cols = patch.shape
    near = (np.minimum(ys, rows - 1 - ys) < reach) | (np.minimum(xs, cols - 1 - xs) < reach)
    return float(near.mean())


def test_a_patchs_band_discount_and_frame_share_are_the_array_expressions() -> None:
    banded = 0
    for patch in _patches():
        for width in (0.5, 2.0, 6.0):
            got, want = peaks.band_discount(patch, width), reference_band_discount(patch, width)
            assert math.isclose(got, want, rel_tol=1e-9), (got, want)
            banded += want < 1.0
        for reach in (0.0, 1.5, 3.0, 7.5):
            assert peaks.frame_share(patch, reach) == reference_frame_share(patch, reach)
    assert banded > 20  # the discount itself was exercised, not only its early returns


def reference_settle(
    support: np.ndarray, base: float, y: float, x: float, radius: float
) -> tuple[float, float]:
    """The mean shift by numpy windows."""
    rows, cols = support.shape
    reach = math.ceil(radius) + 1
    for _ in range(peaks._SETTLE):
        y0, y1 = max(0, round(y) - reach), min(rows, round(y) + reach + 1)
        x0, x1 = max(0, round(x) - reach), min(cols, round(x) + reach + 1)
        ys, xs = np.mgrid[y0:y1, x0:x1]
        inside = (ys - y) ** 2 + (xs - x) ** 2 <= radius * radius
        weight = np.clip(support[y0:y1, x0:x1] - base, 0.0, None) * inside
        total = float(weight.sum())
        if total <= 0.0:
            break
        ny, nx = float((ys * weight).sum()) / total, float((xs * weight).sum()) / total
        done = abs(ny - y) + abs(nx - x) < 0.05
        y, x = ny, nx
        if done:
            break
    return y, x


def test_the_mean_shift_settles_where_the_numpy_windows_did() -> None:
    rng = np.random.default_rng(22)
    moved = 0
    for _ in range(80):
        rows, cols = (int(v) for v in rng.integers(12, 70, 2))
        yy, xx = np.mgrid[:rows, :cols]
        support = rng.normal(0.0, 0.2, (rows, cols))
        for _ in range(int(rng.integers(1, 4))):
            cy, cx, s = rng.uniform(0, rows), rng.uniform(0, cols), rng.uniform(1.5, 9)
            support += rng.uniform(0.5, 3) * np.exp(-((yy - cy) ** 2 + (xx - cx) ** 2) / s**2)
        support = support.astype(np.float32)
        base = float(np.median(support))
        y, x, radius = rng.uniform(0, rows - 1), rng.uniform(0, cols - 1), rng.uniform(1, 12)
        got, want = (
            peaks._settle(support, base, y, x, radius),
            reference_settle(support, base, y, x, radius),
        )
        assert np.allclose(got, want, atol=1e-4), (got, want)
        moved += math.hypot(want[0] - y, want[1] - x) > 1.0
    assert moved > 20


def test_texture_row_norms_are_the_einsum() -> None:
    rng = np.random.default_rng(23)
    for _ in range(20):
        z = (rng.normal(size=(int(rng.integers(1, 5000)), int(rng.integers(1, 8)))) * 10).astype(
            np.float32
        )
        want = np.einsum("ij,ij->i", z, z)
        assert np.allclose(texture._row_norms(z), want, rtol=3e-7, atol=0.0)
