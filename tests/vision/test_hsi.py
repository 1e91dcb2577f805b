import numpy as np
import pytest

from cyborg.daemon.vision.hsi import hue_histogram_rotation, rgb_to_hsi


def _reference(bgr: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    b, g, r = (bgr[..., k].astype(np.float64) for k in range(3))
    num = 0.5 * ((r - g) + (r - b))
    den = np.sqrt((r - g) ** 2 + (r - b) * (g - b)) + 1e-12
    theta = np.degrees(np.arccos(np.clip(num / den, -1, 1)))
    h = np.where(b <= g, theta, 360.0 - theta) * 256.0 / 360.0
    i = (r + g + b) / 3.0
    s = np.where(i > 0, 1.0 - np.minimum(np.minimum(r, g), b) / np.maximum(i, 1e-12), 0.0) * 255
    return h, s, i


def test_matches_gonzalez_woods_formula(rng):
    bgr = rng.integers(0, 256, (100, 100, 3), dtype=np.uint8)
    hsi = rgb_to_hsi(bgr)
    h, s, i = _reference(bgr)
    assert np.abs(hsi.i - i).max() <= 0.5 + 1e-9
    assert np.abs(hsi.s - s).max() <= 1.0
    chromatic = s > 25
    diff = np.abs(hsi.h.astype(float) - h)
    circular = np.minimum(diff, 256 - diff)
    assert circular[chromatic].max() <= 1.5


def test_grey_black_and_defined_mask():
    bgr = np.array([[[0, 0, 0], [128, 128, 128], [0, 0, 200], [30, 30, 31]]], np.uint8)
    hsi = rgb_to_hsi(bgr, grey_saturation=5)
    assert hsi.s[0, 0] == 0 and hsi.i[0, 0] == 0  # black: S = 0, not 255
    assert hsi.h[0, 1] == 0 and hsi.s[0, 1] == 0
    assert hsi.hue_defined.tolist() == [[False, False, True, False]]
    dark = rgb_to_hsi(bgr, grey_saturation=5, min_intensity=100)
    assert not dark.hue_defined[0, 2]


def test_input_not_mutated_and_bad_shapes(rng):
    bgr = rng.integers(0, 256, (8, 9, 3), dtype=np.uint8)
    copy = bgr.copy()
    rgb_to_hsi(bgr)
    assert (bgr == copy).all()
    with pytest.raises(ValueError):
        rgb_to_hsi(bgr[..., 0])
    with pytest.raises(ValueError):
        rgb_to_hsi(bgr.astype(np.float32))


def test_rotation_moves_cut_out_of_a_red_unit():
    hue = np.concatenate([np.arange(240, 256), np.arange(0, 16), np.full(32, 100)]).astype(np.uint8)
    off = hue_histogram_rotation(hue[None, :])
    rotated = (hue[:32].astype(int) + off) % 256
    assert rotated.max() - rotated.min() == 31  # the red run is contiguous after rotation
