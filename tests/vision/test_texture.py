"""Texture rarity and the ``default`` profile: a crack in grain, found and explained; bad
parameters refused."""

import numpy as np
import pytest

from cyborg.daemon.vision.explain import describe
from cyborg.daemon.vision.params import DEFAULT, UNCOMMON, VisionParams
from cyborg.daemon.vision.pipeline import analyze
from cyborg.daemon.vision.texture import descriptors, texture_rarity


def _road(seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    grain = rng.normal(120, 12, (120, 160)).clip(0, 255).astype(np.uint8)
    img = np.repeat(grain[:, :, None], 3, axis=2)
    for x in range(40, 120):  # a thin dark crack, rare only in its neighbourhood's texture
        y = 60 + int(6 * np.sin(x / 9.0))
        img[y : y + 2, x] = 55
    return img


def test_crack_in_grain_is_the_rarest_texture() -> None:
    rare = texture_rarity(_road(), DEFAULT)
    assert np.isfinite(rare).all()
    assert float(rare[60:68, 40:120].max()) > 5 * float(np.median(rare))


def test_default_profile_finds_the_crack_and_is_deterministic() -> None:
    img = _road()
    first, second = analyze(img, DEFAULT), analyze(img.copy(), DEFAULT)
    assert [(p.x, p.y) for p in first.points] == [(p.x, p.y) for p in second.points]
    best = first.points[0]
    assert 35 <= best.x <= 125 and 50 <= best.y <= 72


def test_the_crack_is_explained_by_its_texture() -> None:
    res = analyze(_road(), DEFAULT)
    (texture,) = [e for e in res.explanations[0] if e["plane"] == "texture"]
    assert texture["rarer_than"] >= 0.9
    assert "texture rarer than" in res.descriptions[0]
    assert "texture rarity" in describe(res.explanations[0])


def test_profiles_without_texture_do_not_explain_it() -> None:
    res = analyze(_road(), UNCOMMON)
    assert all(e["plane"] != "texture" for expl in res.explanations for e in expl)


def test_a_step_between_two_surfaces_is_not_rare_brightness() -> None:
    """Beside a bed contact each pixel is judged against its own side; a dark spot differs
    from every side and keeps its contrast."""
    img = np.full((80, 120, 3), 80, np.uint8)
    img[:, 60:] = 160
    img[38:43, 88:93] = 40
    brightness = descriptors(img, (1.5, 4.0), 16.0)[:, :, 2]
    # Within 8 px of the step; the centred surround, half of each side there, would put
    # them half the step's log ratio (0.56) away, ~0.28.
    assert np.abs(brightness[40, 52:68]).max() < 0.1
    assert brightness[40, 90] < -0.5  # the spot: about 2.5 times darker than its rock


def test_presmoothing_conditions_the_segmentation_not_the_texture() -> None:
    """A 1 px checkerboard of the grey field's own mean: only its texture tells it apart,
    and the Gaussian that quiets sensor noise before segmentation would erase it."""
    rng = np.random.default_rng(5)
    img = np.repeat(rng.normal(120, 3, (120, 160)).clip(0, 255).astype(np.uint8)[..., None], 3, 2)
    yy, xx = np.mgrid[50:70, 70:90]
    img[50:70, 70:90] = np.where((yy + xx) % 2 == 0, 100, 140).astype(np.uint8)[..., None]
    res = analyze(img, DEFAULT.replace(presmooth=1.5))
    assert float(res.hsi.i[52:68, 72:88].std()) < 3.0  # segmented: the checkerboard smoothed
    best = res.points[0]
    assert 65 <= best.x <= 95 and 45 <= best.y <= 75
    (texture,) = [e for e in res.explanations[0] if e["plane"] == "texture"]
    assert texture["rarer_than"] >= 0.9


def test_flat_image_has_no_points_with_texture() -> None:
    assert analyze(np.full((40, 50, 3), 90, np.uint8), DEFAULT).points == []


@pytest.mark.parametrize(
    "bad",
    [
        {"texture_weight": -1.0},
        {"texture_trim": 1.0},
        {"texture_scales": ()},
        {"texture_blur": 0.0},
        {"texture_surround": 3.0},
        {"fused_isotropy": 2.0},
    ],
)
def test_bad_texture_parameters_are_refused(bad: dict) -> None:
    with pytest.raises(ValueError):
        VisionParams(**bad)
