"""Texture rarity: how unlike the rest of the image each pixel's neighbourhood is.

The seed's authors list microtexture among what failed. H, S and I classes judge a pixel by
its own value, so a crack, a pitted tile defect or a grainy rock on smooth soil, which differ
from their surroundings in local contrast more than in any one value, hardly register.

Each pixel gets a descriptor: the local standard deviation of intensity at each of
``texture_scales`` (Gaussian sigmas, analysed-image pixels), its brightness against its
surroundings (the log ratio of the intensity at the finest scale to that at
``texture_surround``, on the side likest it), and, for
colour images, two opponent chroma values (red - green, yellow - blue). Its rarity is the
squared Mahalanobis distance from the image's typical descriptor, the negative
log-likelihood under one Gaussian model of the image's textures (Reed & Yu's RX detector on
local features). Blurs of sigma 4 and more run on a grid of 2 x 2 means (``grid.surround``).
Brightness enters only against the surroundings: how dark a pixel is
overall is the I plane's business, and an absolute level makes whole shadowed ledges rare.
It is a ratio (a shadow counts by how many times darker it is), against the likest of five
surroundings (``_likest_side``) rather than the centred one, so the step between two common
surfaces does not read as rare brightness.

Mean and covariance are estimated robustly, by concentration steps (the C-step of
Rousseeuw & Van Driessen's FAST-MCD): each step refits on the ``1 - texture_trim`` share of
pixels nearest the current fit. Plain RX lets a big target (a plant over 20 % of the frame)
widen the covariance until the target looks common.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from . import grid
from .kernels import kernel
from .order import quantiles
from .params import VisionParams

__all__ = ["descriptors", "texture_rarity"]

_FIT_PIXELS = 1 << 14
"""Most pixels (on a regular lattice) the model is fitted on: 5x5 moments need few."""
_MIN_FIT = 8
"""Pixels per descriptor dimension below which no texture model is fitted."""
_OPPONENT = np.array([[1.0, 1.0, 1.0], [0.0, -3.0, 3.0], [-3.0, 1.5, 1.5]], np.float32) / 765.0
"""8-bit B, G, R to intensity (the I of HSI), red - green and yellow - blue, on 0..1."""
_FLOOR = 0.1
"""Brightness ratios are taken on I + 0.1 (I on 0..1): a shadow or a dark crack counts by how
many times darker it is, but sensor noise in near-black pixels is not blown up into ratios."""


def descriptors(bgr: np.ndarray, scales: tuple[float, ...], surround: float) -> np.ndarray:
    """Per-pixel descriptors, (M, N, len(scales) + 3) float32, on the 0..1 intensity scale:
    contrast at each scale, brightness against the surroundings, chroma.

    Examples
    --------
    >>> img = np.full((20, 20, 3), 100, np.uint8)
    >>> descriptors(img, (1.5, 4.0), 16.0).shape
    (20, 20, 5)
    >>> round(float(descriptors(img, (1.5,), 16.0)[10, 10, 0]), 2)  # flat: no local contrast
    0.0
    """
    opponent = cv2.transform(bgr.astype(np.float32), _OPPONENT)
    grey = cv2.extractChannel(opponent, 0)
    ratio = cv2.log(grey + _FLOOR)  # brightness against the surroundings is a ratio
    # Centred on the image's mean: E[I^2] - E[I]^2 in float32 cancels badly on bright rock.
    planes = _planes(opponent, np.float32(cv2.mean(grey)[0]), ratio)
    shape = grey.shape
    # Mean and mean square of the intensity at the finest scale, chroma and log brightness.
    fine = cv2.GaussianBlur(planes, (0, 0), scales[0])
    feats = np.empty((*shape, len(scales) + 3), np.float32)
    blocks = None  # the moments' 2 x 2 means, made once for the wide scales
    for k, sigma in enumerate(scales):
        if sigma == scales[0]:
            blurred = fine
        elif (f := grid.surround_grid(shape, sigma)) == 2:
            blocks = _moment_blocks(planes) if blocks is None else blocks
            blurred = grid.expand(grid.grid_blur(blocks, sigma, f), f, shape)
        else:
            blurred = grid.expand(
                *grid.surround(np.ascontiguousarray(planes[..., :2]), sigma), shape
            )
        _contrast(blurred, feats, k)
    around = grid.expand(*grid.surround(ratio, surround), shape)
    _likest_side(fine, around, round(surround), feats, len(scales))  # and the chroma
    return feats


@kernel
def _planes(opponent: np.ndarray, mean: np.float32, ratio: np.ndarray) -> np.ndarray:
    """(M, N, 5) the intensity (``opponent``'s channel 0) less ``mean``, its square, the two
    chroma channels and ``ratio``: float32, in one pass where splitting, subtracting,
    squaring and merging took six."""
    rows, cols = ratio.shape
    planes = np.empty((rows, cols, 5), np.float32)
    for y in range(rows):  # by rows: the inner loop runs over one row's memory
        src, level, five = opponent[y], ratio[y], planes[y]
        for x in range(cols):
            centred = src[x, 0] - mean
            five[x, 0], five[x, 1], five[x, 2] = centred, centred * centred, src[x, 1]
            five[x, 3], five[x, 4] = src[x, 2], level[x]
    return planes


@kernel
def _moment_blocks(planes: np.ndarray) -> np.ndarray:
    """``grid.block_means`` of ``planes``' first two channels (the centred intensity and its
    square) over 2 x 2 blocks, bit for bit, without their full-size copy: each block's four
    values (``grid.block_pair``) summed in the order OpenCV's area reduction of two channels
    sums them."""
    rows, cols = planes.shape[:2]
    out = np.empty(((rows + 1) // 2, (cols + 1) // 2, 2), np.float32)
    quarter = np.float32(0.25)
    for by in range(out.shape[0]):
        y0, y1 = grid.block_pair(by, rows)
        for bx in range(out.shape[1]):
            x0, x1 = grid.block_pair(bx, cols)
            for k in range(2):
                total = planes[y0, x0, k] + planes[y0, x1, k]
                total = (total + planes[y1, x0, k]) + planes[y1, x1, k]
                out[by, bx, k] = total * quarter
    return out


@kernel
def _contrast(blurred: np.ndarray, feats: np.ndarray, k: int) -> None:
    """``feats[..., k]``: the local standard deviation from ``blurred``'s mean and mean
    square (its channels 0 and 1), float32 as the whole-array expression."""
    zero = np.float32(0.0)
    for y in range(blurred.shape[0]):
        for x in range(blurred.shape[1]):
            mean = blurred[y, x, 0]
            feats[y, x, k] = np.sqrt(max(blurred[y, x, 1] - mean * mean, zero))


@kernel
def _likest_side(
    fine: np.ndarray, around: np.ndarray, reach: int, feats: np.ndarray, k: int
) -> None:
    """``feats[..., k]``: own - around, own the log brightness (``fine``'s channel 4), with
    ``around`` taken where it is likest own: centred, or ``reach`` pixels up, down, left or
    right (the edge repeated beyond the frame); the first likest in that order. The chroma
    (``fine``'s channels 2 and 3) goes to ``feats[..., k + 1 :]`` in the same pass.

    Next to a step between two common surfaces (a bed contact, the sky's edge, a rock's
    lit side against its shadow) the centred surround mixes both and every pixel there
    looks brighter or darker than it; one side is its own surface and says it is not. A
    pebble, a vein or a stain differs from every side and keeps its contrast.
    """
    rows, cols = around.shape
    for y in range(rows):
        up, down = max(y - reach, 0), min(y + reach, rows - 1)
        for x in range(cols):
            own = fine[y, x, 4]
            best = own - around[y, x]
            gap = abs(best)
            for side in (
                around[up, x],
                around[down, x],
                around[y, max(x - reach, 0)],
                around[y, min(x + reach, cols - 1)],
            ):
                here = abs(own - side)
                if here < gap:
                    best, gap = own - side, here
            feats[y, x, k] = best
            feats[y, x, k + 1], feats[y, x, k + 2] = fine[y, x, 2], fine[y, x, 3]


def texture_rarity(bgr: np.ndarray, params: VisionParams) -> np.ndarray:
    """Squared robust Mahalanobis distance of each pixel's descriptor, (M, N) float32.

    Grey images (all channels equal) carry no chroma; their chroma rows are constant and
    the covariance is regularised so they count for nothing.

    Examples
    --------
    >>> from cyborg.daemon.vision.params import DEFAULT
    >>> img = np.full((60, 60, 3), (60, 100, 140), np.uint8)
    >>> img[::2] += 8                                   # a fine, common grain
    >>> img[28:32, 10:50] = (60, 100, 140)              # a smooth streak: rare texture
    >>> rare = texture_rarity(img, DEFAULT)
    >>> bool(rare[30, 30] > 10 * np.median(rare))
    True
    """
    feats = descriptors(bgr, params.texture_scales, params.texture_surround)
    rows, cols, dims = feats.shape
    flat = feats.reshape(-1, dims)
    step = math.ceil(math.sqrt(rows * cols / _FIT_PIXELS))
    sample = feats[::step, ::step].reshape(-1, dims).astype(np.float64)
    if len(sample) < _MIN_FIT * dims:  # too few pixels to tell common texture from rare
        return np.zeros((rows, cols), np.float32)
    mean, cov = _moments(sample)
    ridge = 1e-6 * np.eye(dims)
    for _ in range(params.texture_steps):
        dist = _mahalanobis(sample, mean, cov + ridge)
        keep = dist <= quantiles(dist, 1.0 - params.texture_trim)
        mean, cov = _moments(sample[keep])
    return _mahalanobis(flat, mean, cov + ridge).reshape(rows, cols)


def _moments(sample: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``sample.mean(0)`` and ``np.cov(sample, rowvar=False)`` of (n, d) float64 rows,
    value for value: numpy's own steps on the same layouts (its column sums run row by row,
    in order; the product is the same BLAS call), with the mean and the centring in one pass,
    where numpy's broadcasts over d columns took most of the time."""
    mean, centred = _mean_centred(sample)
    x = centred.T  # np.cov's (d, n) view of its (n, d) copy
    cov = np.dot(x, x.T.conj())
    cov *= np.true_divide(1, len(sample) - 1)
    return mean, cov


@kernel
def _mean_centred(sample: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The column means of (n, d) float64 rows (summed in row order, then divided by n)
    and the rows less them."""
    rows, dims = sample.shape
    total = np.zeros(dims)
    for i in range(rows):
        row = sample[i]
        for j in range(dims):
            total[j] += row[j]
    mean = total / rows
    centred = np.empty_like(sample)
    for i in range(rows):
        row, diff = sample[i], centred[i]
        for j in range(dims):
            diff[j] = row[j] - mean[j]
    return mean, centred


@kernel
def _centred(x: np.ndarray, mean: np.ndarray) -> np.ndarray:
    """The rows of ``x`` less ``mean`` (float32), each difference in ``x``'s precision,
    rounded to float32: ``(x - mean).astype(np.float32)`` in one pass, where numpy
    broadcasts over the few columns slowly."""
    rows, dims = x.shape
    out = np.empty((rows, dims), np.float32)
    for i in range(rows):
        row, diff = x[i], out[i]
        for j in range(dims):
            diff[j] = row[j] - mean[j]
    return out


def _mahalanobis(x: np.ndarray, mean: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """Squared Mahalanobis distances of the rows of ``x``, float32."""
    values, vectors = np.linalg.eigh(cov)
    whiten = (vectors / np.sqrt(np.maximum(values, 1e-12))).astype(np.float32)
    return _row_norms(_centred(x, mean.astype(np.float32)) @ whiten)


@kernel
def _row_norms(z: np.ndarray) -> np.ndarray:
    """The squared norm of each row of ``z`` (float32, summed in order): numpy's
    ``einsum("ij,ij->i")`` went row by row over a few columns at a time, slowly."""
    rows, dims = z.shape
    out = np.empty(rows, np.float32)
    for i in range(rows):
        row = z[i]
        total = np.float32(0.0)
        for j in range(dims):
            total += row[j] * row[j]
        out[i] = total
    return out
