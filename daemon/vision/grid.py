"""Wide Gaussian blurs on a grid of block means, for the maps and surroundings of the core.

A sigma-s blur removes everything above ~1/(2 pi s) cycles/px, so an image can first be
averaged over f x f blocks and blurred on that grid with the residual sigma
sqrt(s^2 - (f^2 - 1)/12) / f (a block mean is a box of variance (f^2 - 1)/12): f^2 times fewer
pixels and an f times shorter kernel, within 1 % of the exact blur across a step. The interest
map blurs at B this way; the shadow gate's surroundings and texture's moments and surroundings
(sigma 4 to 16 analysed pixels) on a grid of 2 x 2 means. An image bigger than the working size
is reduced to it in whole blocks first, for the same reason (``reduce_to``).
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .kernels import kernel

__all__ = [
    "block_means",
    "block_pair",
    "expand",
    "grid_blur",
    "reduce_to",
    "surround",
    "surround_grid",
]

_SURROUND_GRID = 2
"""Block size of a surround's grid: 2 x 2 keeps a sigma-4 blur within 1 % of the exact one."""
_MIN_SURROUND = 4.0
"""Surroundings of a smaller sigma (analysed pixels) are blurred at full resolution."""


def block_means(image: np.ndarray, f: int) -> np.ndarray:
    """Mean over f x f blocks, the frame padded by reflection to a multiple of f.

    Examples
    --------
    >>> img = np.arange(16, dtype=np.float32).reshape(4, 4)
    >>> block_means(img, 2).tolist()
    [[2.5, 4.5], [10.5, 12.5]]
    >>> block_means(np.zeros((5, 3, 4), np.float32), 2).shape  # any channels, odd sides
    (3, 2, 4)
    """
    if f == 1:
        return image
    rows, cols = image.shape[:2]
    pad_r, pad_c = (-rows) % f, (-cols) % f
    if pad_r or pad_c:
        image = cv2.copyMakeBorder(image, 0, pad_r, 0, pad_c, cv2.BORDER_REFLECT_101)
    return cv2.resize(
        image, (image.shape[1] // f, image.shape[0] // f), interpolation=cv2.INTER_AREA
    )


@kernel
def block_pair(i: int, n: int) -> tuple[int, int]:
    """The two indices along a side of ``n`` that 2 x 2 block ``i`` of :func:`block_means`
    averages: 2i and 2i + 1, the second mirrored back to n - 2 past the end as its padding
    mirrors it (reflect-101); for a kernel that makes the block means without the padded
    copy."""
    first = 2 * i
    return first, first + 1 if first + 1 < n else n - 2


def grid_blur(
    grid: np.ndarray, sigma: float, f: int, border: int = cv2.BORDER_REFLECT_101
) -> np.ndarray:
    """Blur a grid of f x f block means so the result equals a ``sigma`` blur of the image."""
    residual = math.sqrt(max(sigma**2 - (f * f - 1) / 12.0, 1e-6)) / f
    return cv2.GaussianBlur(grid, (0, 0), residual, borderType=border)


def expand(grid: np.ndarray, f: int, shape: tuple[int, int]) -> np.ndarray:
    """A grid of f x f blocks back at the image's ``shape``, bilinear between block centres.

    Examples
    --------
    >>> grid = np.array([[0.0, 4.0]], np.float32)
    >>> expand(grid, 2, (1, 3)).tolist()  # block centres at x = 0.5 and 2.5
    [[0.0, 1.0, 3.0]]
    """
    if f == 1:
        return grid
    rows, cols = grid.shape[:2]
    return cv2.resize(grid, (cols * f, rows * f))[: shape[0], : shape[1]]


def surround(image: np.ndarray, sigma: float) -> tuple[np.ndarray, int]:
    """A ``sigma`` blur of ``image`` and the block size of the grid it is on (``expand``
    brings it back); wide surroundings are blurred on a grid of 2 x 2 means.

    Examples
    --------
    >>> img = np.zeros((64, 64), np.float32)
    >>> img[30:, :] = 1.0                               # a contact between two beds
    >>> wide, f = surround(img, 6.0)
    >>> f, wide.shape
    (2, (32, 32))
    >>> exact = cv2.GaussianBlur(img, (0, 0), 6.0)
    >>> bool(np.abs(expand(wide, f, img.shape) - exact).max() < 0.01)
    True
    """
    f = surround_grid(image.shape, sigma)
    return grid_blur(block_means(image, f), sigma, f), f


def surround_grid(shape: tuple[int, ...], sigma: float) -> int:
    """The block size :func:`surround` blurs an image of this shape on at this sigma: 2 for a
    wide surround, 1 (full resolution) for a narrow one or a small image."""
    return _SURROUND_GRID if sigma >= _MIN_SURROUND and min(shape[:2]) >= 16 else 1


def reduce_to(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``image`` reduced to ``size`` (columns, rows) by area averaging: whole n x n blocks
    first (the last < n rows and columns left out), then bilinear for the part of the
    reduction left (under 1.5x once n >= 2).

    OpenCV's area reduction at a fractional scale weighs every source pixel by its overlap,
    3.3 ms for a 1 MP image to the 0.13 MP working size, against 1.4 for whole 3 x 3 blocks
    and 0.3 for the bilinear rest. The box has already removed what the rest would alias.

    Examples
    --------
    >>> img = np.zeros((300, 400, 3), np.uint8)
    >>> img[:, 200:] = 200
    >>> small = reduce_to(img, (123, 92))
    >>> small.shape, int(small[50, 10, 0]), int(small[50, 110, 0])
    ((92, 123, 3), 0, 200)
    """
    rows, cols = image.shape[:2]
    n = min(rows // size[1], cols // size[0])
    if n < 2:
        return cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    # Cropped to whole blocks rather than padded: a view, where padding copies a 12 MP photo.
    # The rest maps each output pixel's centre onto the whole input, the crop included.
    blocks = block_means(image[: rows - rows % n, : cols - cols % n], n)
    if blocks.shape[1::-1] == size and not (rows % n or cols % n):
        return blocks
    sx, sy = cols / size[0] / n, rows / size[1] / n
    to_blocks = np.array([[sx, 0.0, 0.5 * sx - 0.5], [0.0, sy, 0.5 * sy - 0.5]])
    flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
    return cv2.warpAffine(blocks, to_blocks, size, flags=flags, borderMode=cv2.BORDER_REPLICATE)
