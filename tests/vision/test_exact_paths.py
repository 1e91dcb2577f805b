"""The fast paths of the fixed cost compute exactly what their plain definition says, bit for
bit: the co-occurrence diagonal's persistence and valleys, the sorted quantiles against
numpy's, the roundness and texture descriptor kernels against the whole-array expressions
they replace."""

from __future__ import annotations

import itertools

import cv2
import numpy as np
import pytest

from cyborg.daemon.sim.scene import outcrop_scene
from cyborg.daemon.vision import cooccurrence, interest, order, texture


def _profiles(count: int) -> list[np.ndarray]:
    """Diagonal-like profiles: noise, plateaus with zeros (ties), smooth multi-peaked."""
    rng = np.random.default_rng(4)
    out = []
    for t in range(count):
        if t % 3 == 0:
            prof = rng.random(256)
        elif t % 3 == 1:
            prof = np.round(rng.random(256) * 4) / 4
            prof[rng.random(256) < 0.3] = 0.0
        else:
            prof = np.convolve(rng.random(256) ** 8, np.ones(9), "same")
        out.append(prof)
    return out


def reference_persistence(prof: np.ndarray) -> dict[int, float]:
    """Union by height, written out: each maximum, how far the profile falls from it before
    a higher one (ties: the lower value is higher)."""
    owner = np.full(len(prof), -1)
    peaks: dict[int, float] = {}
    for i in sorted(range(len(prof)), key=lambda v: (-prof[v], v)):
        if prof[i] <= 0:
            break
        sides = {int(owner[j]) for j in (i - 1, i + 1) if 0 <= j < len(prof) and owner[j] >= 0}
        if not sides:
            owner[i] = i
            continue
        top = min(sides, key=lambda g: (-prof[g], g))
        for g in sides - {top}:
            peaks[g] = float(prof[g] - prof[i])
            owner[owner == g] = top
        owner[i] = top
    for g in set(owner[owner >= 0].tolist()) - set(peaks):
        peaks[int(g)] = float(prof[g])
    return peaks


def reference_valley(prof: np.ndarray, a: int, b: int) -> int:
    """The middle of the middle run of the lowest values between a and b."""
    seg = prof[a : b + 1]
    low = np.flatnonzero(seg <= seg.min() + 1e-9 * max(seg.max(), 1e-30))
    runs = np.split(low, np.flatnonzero(np.diff(low) > 1) + 1)
    deepest = runs[len(runs) // 2]
    return a + int((deepest[0] + deepest[-1]) // 2)


def test_persistence_and_valleys_match_their_definitions() -> None:
    rng = np.random.default_rng(5)
    for prof in _profiles(300):
        fast = cooccurrence._persistence(prof)
        ref = reference_persistence(prof)
        assert sorted(ref) == np.flatnonzero(fast >= 0).tolist()
        assert all(fast[g] == p for g, p in ref.items())
        centres = sorted(rng.choice(256, int(rng.integers(2, 9)), replace=False).tolist())
        ends = cooccurrence._valleys(prof, np.array(centres, np.int64)).tolist()
        assert ends == [reference_valley(prof, a, b) for a, b in itertools.pairwise(centres)]


def _same(a: object, b: object) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_sorted_quantiles_are_numpys(dtype: type) -> None:
    rng = np.random.default_rng(7)
    for t in range(400):
        n = int(rng.integers(1, 5000))
        values = [rng.random(n), np.round(rng.normal(size=n), 1), rng.integers(0, 4, n)][t % 3]
        values = values.astype(dtype).reshape(-1, 1) if t % 2 else values.astype(dtype)
        if t % 97 == 0:
            values.ravel()[0] = np.nan
        for q in ((50.0, 99.5), 99.5, 50.0, (0.0, 100.0)):
            assert _same(order.percentiles(values, q), np.percentile(values, q))
        for q in (0.75, (0.25, 0.5), 1.0, 0):
            assert _same(order.quantiles(values, q), np.quantile(values, q))
        assert _same(order.median(values), np.median(values))


def reference_roundness(blurred: np.ndarray, sigma: float, share: float) -> np.ndarray:
    """Roundness as whole-array expressions of the Hessian's eigenvalues."""
    wider = cv2.GaussianBlur(blurred, (0, 0), np.sqrt(3.0) * sigma)
    border = cv2.BORDER_REFLECT_101
    lxx = cv2.Sobel(wider, cv2.CV_32F, 2, 0, ksize=3, scale=0.25, borderType=border)
    lyy = cv2.Sobel(wider, cv2.CV_32F, 0, 2, ksize=3, scale=0.25, borderType=border)
    lxy = cv2.Sobel(wider, cv2.CV_32F, 1, 1, ksize=3, scale=0.25, borderType=border)
    radius = cv2.magnitude(cv2.subtract(lxx, lyy) * 0.5, lxy)
    mean = cv2.add(lxx, lyy) * 0.5
    lmax, lmin = mean + radius, mean - radius
    eps = np.float32(interest._FLAT * max(float(-lmin.min()), 0.0))
    iso = np.where(
        lmin < eps, np.clip((lmax - eps) / np.minimum(lmin - eps, -1e-12), 0.0, 1.0), 0.0
    )
    return (1.0 - share + share * iso).astype(np.float32)


def test_roundness_kernel_matches_the_array_expression() -> None:
    rng = np.random.default_rng(8)
    for t in range(60):
        shape = (int(rng.integers(5, 120)), int(rng.integers(5, 120)))
        noise = rng.normal(size=shape).astype(np.float32) * np.float32(rng.exponential(10))
        grid = np.zeros(shape, np.float32) if t % 7 == 0 else cv2.GaussianBlur(noise, (0, 0), 2.0)
        for sigma, share in ((1.0, 0.5), (2.5, 1.0)):
            assert _same(
                interest._roundness(grid, sigma, share), reference_roundness(grid, sigma, share)
            )


def reference_descriptors(
    bgr: np.ndarray, scales: tuple[float, ...], surround: float
) -> np.ndarray:
    """Contrast planes, brightness against the likest side and chroma as whole-array
    OpenCV expressions, from the same blurred moments."""
    grey, red_green, yellow_blue = cv2.split(
        cv2.transform(bgr.astype(np.float32), texture._OPPONENT)
    )
    intensity = cv2.subtract(grey, float(cv2.mean(grey)[0]))
    moments = cv2.merge([intensity, cv2.multiply(intensity, intensity)])
    ratio = cv2.log(grey + texture._FLOOR)
    fine = cv2.GaussianBlur(cv2.merge([moments, red_green, yellow_blue, ratio]), (0, 0), scales[0])
    grid = texture.grid
    planes = []
    for sigma in scales:
        blurred = (
            fine if sigma == scales[0] else grid.expand(*grid.surround(moments, sigma), grey.shape)
        )
        mean, square = cv2.extractChannel(blurred, 0), cv2.extractChannel(blurred, 1)
        planes.append(cv2.sqrt(np.maximum(square - cv2.multiply(mean, mean), 0.0)))
    around = grid.expand(*grid.surround(ratio, surround), grey.shape)
    own, reach = cv2.extractChannel(fine, 4), round(surround)
    rows, cols = own.shape
    padded = cv2.copyMakeBorder(around, reach, reach, reach, reach, cv2.BORDER_REPLICATE)
    best, gap = cv2.subtract(own, around), cv2.absdiff(own, around)
    for dy, dx in ((0, reach), (2 * reach, reach), (reach, 0), (reach, 2 * reach)):
        side = padded[dy : dy + rows, dx : dx + cols]
        here = cv2.absdiff(own, side)
        cv2.copyTo(cv2.subtract(own, side), cv2.compare(here, gap, cv2.CMP_LT), best)
        cv2.min(gap, here, dst=gap)
    return cv2.merge([*planes, best, cv2.extractChannel(fine, 2), cv2.extractChannel(fine, 3)])


def test_texture_descriptor_kernels_match_the_array_expressions() -> None:
    rng = np.random.default_rng(9)
    images = [outcrop_scene(seed, (108, 144)).image for seed in range(3)]
    images += [
        rng.integers(0, 255, (int(rng.integers(8, 70)), 50, 3), dtype=np.uint8) for _ in range(6)
    ]
    for img in images:
        for scales, surround in (((1.5, 4.0), 16.0), ((1.5,), 16.0), ((2.0, 2.0, 6.0), 9.0)):
            assert _same(
                texture.descriptors(img, scales, surround),
                reference_descriptors(img, scales, surround),
            )
