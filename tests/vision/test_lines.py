"""Line rarity: a faint vein among strong bed contacts is found, a contact is no line, a line
along a shadow is the shadow's; bad parameters refused."""

import numpy as np
import pytest

from cyborg.daemon.vision.explain import describe
from cyborg.daemon.vision.lines import line_rarity, line_shade
from cyborg.daemon.vision.params import DEFAULT, VisionParams
from cyborg.daemon.vision.pipeline import analyze


def _bedded(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Brown rock between a pale bed (a strong contact, then a thin red bed) and a grey one,
    with a faint calcite vein 2 px wide across the brown bed; the vein's mask."""
    rng = np.random.default_rng(seed)
    rows, cols = 150, 200
    y = np.arange(rows)[:, None] + 6 * np.sin(np.arange(cols)[None, :] / 23.0)
    img = np.empty((rows, cols, 3), np.float32)
    img[:] = (70, 85, 105)
    img[y < 40] = (150, 165, 180)
    img[(y >= 40) & (y < 46)] = (40, 50, 90)
    img[y >= 110] = (60, 60, 62)
    img += rng.normal(0, 4, img.shape)
    vein = np.zeros((rows, cols), bool)
    for t in np.linspace(0, 1, 400):
        x, yy = int(60 + 60 * t), int(62 + 30 * t)
        vein[yy : yy + 2, x] = True
    img[vein] = (100, 115, 135)
    return np.clip(img, 0, 255).astype(np.uint8), vein


def _on(mask: np.ndarray, x: float, y: float, reach: int = 4) -> bool:
    r, c = round(y), round(x)
    return bool(mask[max(0, r - reach) : r + reach + 1, max(0, c - reach) : c + reach + 1].any())


def test_a_faint_vein_among_strong_contacts_is_the_top_point() -> None:
    """The contacts are the rarest texture in view and the thin red bed a rare class; the vein
    differs from the rock on both its sides, which no contact does."""
    found = {w: 0 for w in (0.0, DEFAULT.line_weight)}
    for seed in range(5):
        img, vein = _bedded(seed)
        for weight in found:
            best = analyze(img, DEFAULT.replace(line_weight=weight)).points[0]
            found[weight] += _on(vein, best.x, best.y)
    assert found[DEFAULT.line_weight] == 5
    assert found[0.0] < 5  # what the line term is for


def test_the_vein_is_explained_as_a_thin_bright_line() -> None:
    res = analyze(_bedded(0)[0], DEFAULT)
    (line,) = [e for e in res.explanations[0] if e["plane"] == "line"]
    assert line["contrast"] > 8 and line["units"] >= 0.5 and line["share"] >= 0.2
    assert res.descriptions[0].endswith("; a thin bright line")
    assert "; bar +" in describe(res.explanations[0])


def test_grain_and_contacts_alone_are_not_called_lines() -> None:
    img, vein = _bedded(0)
    rng = np.random.default_rng(1)
    rock = np.array([70, 85, 105]) + rng.normal(0, 4, (int(vein.sum()), 3))
    img[vein] = rock.clip(0, 255).astype(np.uint8)  # the vein painted over with its rock
    res = analyze(img, DEFAULT)
    assert res.points
    assert not any("line" in d for d in res.descriptions)
    assert all(e["units"] < 0.5 for expl in res.explanations for e in expl if e["plane"] == "line")


def test_a_contact_is_no_line_and_a_crack_is_a_dark_one() -> None:
    img, vein = _bedded(1)
    z = line_rarity(img, DEFAULT)
    assert z.dtype == np.float32 and np.isfinite(z).all()
    assert z[vein].mean() > 10
    contact = np.abs(z[30:50, 150:190])  # the pale bed's contact, away from the vein
    assert np.median(contact) < 2
    img[100:102, 20:120] = 30  # a dark crack in the brown bed
    assert line_rarity(img, DEFAULT)[100, 40:100].max() < -10


def test_a_line_along_a_shadow_is_shade_end_to_end() -> None:
    """A ledge shadow's thin end escapes the shadow gate (thin untinted lines are cracks to
    it); as part of a line mostly in shade it is shade."""
    rare = np.zeros((40, 100), np.float32)
    rare[20, 10:90] = 50.0
    rare[32, 10:40] = 50.0  # a crack of its own, apart
    shade = np.zeros((40, 100), np.float32)
    shade[17:24, 10:70] = 0.9
    gate = line_shade(rare, shade)
    assert gate[20, 85] == 1.0
    assert gate[32, 20] == 0.0


def test_flat_and_tiny_images_have_no_lines() -> None:
    flat = np.full((50, 60, 3), 120, np.uint8)
    assert not line_rarity(flat, DEFAULT).any()
    assert analyze(flat, DEFAULT).points == []
    assert line_rarity(np.zeros((1, 1, 3), np.uint8), DEFAULT).shape == (1, 1)


@pytest.mark.parametrize(
    "bad",
    [
        {"line_weight": -1.0},
        {"line_weight": float("nan")},
        {"line_width": 0.0},
        {"line_width": float("inf")},
        {"line_length": 0.5},
    ],
)
def test_bad_line_parameters_are_refused(bad: dict) -> None:
    with pytest.raises(ValueError, match="line_"):
        VisionParams(**bad)
