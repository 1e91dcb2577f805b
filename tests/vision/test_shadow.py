"""Shadow likelihood (``vision.shadow``) and the gate that keeps shade out of the interest."""

from __future__ import annotations

import numpy as np
import pytest

from cyborg.daemon.sim.scene import SKY_SHADE
from cyborg.daemon.vision.params import DEFAULT, UNCOMMON, VisionParams
from cyborg.daemon.vision.pipeline import analyze
from cyborg.daemon.vision.shadow import _shade, shadow_likelihood

RED_ROCK = (60, 80, 150)


def rock(colour, shape=(120, 200), seed=0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.asarray(colour, np.float64) + rng.normal(0, 3, (*shape, 3))


def wet(img: np.ndarray, mask: np.ndarray) -> None:
    """Wet rock: darker, its colour deepened (``daemon.scene``'s wet stain)."""
    host = img[mask]
    grey = host.mean(axis=1, keepdims=True)
    img[mask] = (grey + (host - grey) * 1.6) * 0.55


def u8(img: np.ndarray) -> np.ndarray:
    return np.clip(img, 0, 255).astype(np.uint8)


def test_sky_shade_is_shadow_and_a_wet_stain_is_not() -> None:
    img = rock(RED_ROCK)
    img[30:38, 20:180] *= SKY_SHADE
    stain = np.zeros(img.shape[:2], bool)
    stain[75:95, 90:110] = True
    wet(img, stain)
    shade = shadow_likelihood(u8(img), DEFAULT)
    assert shade[32:36, 30:170].mean() > 0.7
    assert shade[stain].max() < 0.1
    assert shade[60:70].max() < 0.1  # lit rock


def test_untinted_shade_counts_only_on_coloured_rock() -> None:
    for colour, expected in ((RED_ROCK, True), ((150, 152, 156), False)):
        img = rock(colour)
        img[30:38, 20:180] *= 0.45  # overcast shade: darker, the same colour
        shade = shadow_likelihood(u8(img), DEFAULT)
        assert bool(shade[32:36, 30:170].mean() > 0.7) is expected, colour


def test_a_grey_image_has_no_shadow_evidence() -> None:
    img = u8(rock((120, 120, 120)).mean(axis=2, keepdims=True).repeat(3, axis=2))
    img[30:38, 20:180] //= 3
    assert float(shadow_likelihood(img, DEFAULT).max()) == 0.0
    gated, plain = analyze(img, DEFAULT), analyze(img, DEFAULT.replace(shadow_gate=0.0))
    assert [(p.x, p.y) for p in gated.points] == [(p.x, p.y) for p in plain.points]


def test_a_shadow_across_a_bed_contact_is_the_shade_of_both_beds() -> None:
    """Red sandstone above, buff below: the surroundings' mean is neither bed, so only the
    comparison with each bed on its side recognises the shadow straddling the contact."""
    img = rock(RED_ROCK)
    img[60:] = rock((110, 150, 190))[60:]
    img[52:68, 30:170] *= SKY_SHADE
    shade = shadow_likelihood(u8(img), DEFAULT)
    assert shade[54:66, 40:160].mean() > 0.8
    assert shade[54:66, 40:160].min() > 0.3


def test_a_crack_is_not_a_shadow_and_a_shadows_edge_is() -> None:
    """The same overcast darkening on coloured rock: a 2 px crack is at most partly shade (a
    ledge casts a band; the fine scale's blur spreads the crack's darkness over 5 px), an
    8 px band is, out to its half-lit edge."""
    img = rock(RED_ROCK)
    img[30:32, 20:180] *= 0.45
    img[80:88, 20:180] *= 0.45
    shade = shadow_likelihood(u8(img), DEFAULT)
    assert shade[30:32, 30:170].max() < 0.3
    assert shade[80:88, 30:170].mean() > 0.8
    assert shade[[79, 88], 30:170].mean() > 0.6  # the edge rows, half lit at the fine scale


def test_a_thin_sky_lit_shadow_stays_shade() -> None:
    """The opening is for untinted lines: a ledge shadow seen from far off is as thin as a
    crack, and if it turns blue it is still the sky's shade (the procedural world's 300 m
    mosaics lost their stain to 2-4 px ledge shadows the opening had taken out of the gate)."""
    img = rock(RED_ROCK)
    img[30:32, 20:180] *= 0.45  # a 2 px crack: untinted
    img[80:82, 20:180] *= SKY_SHADE  # a 2 px ledge shadow: lit by the sky alone
    shade = shadow_likelihood(u8(img), DEFAULT)
    assert shade[30:32, 30:170].max() < 0.3
    assert shade[80:82, 30:170].min() > 0.6


def crack_and_overcast_lens(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Red rock with an oblique 3 px crack (30 % of the light) and an overcast ledge shadow,
    a lens 8 px thick tapering to points at both ends (45 %): both dark and untinted."""
    img = rock(RED_ROCK, shape=(120, 240), seed=seed)
    yy, xx = np.mgrid[:120, :240]
    crack = (np.abs(yy - (0.6 * xx - 10)) < 1.5) & (xx > 30) & (xx < 110)
    img[crack] *= 0.3
    thick = np.clip(np.sin(np.pi * (xx - 130) / 100), 0, 1) ** 0.7 * ((xx >= 130) & (xx < 230))
    lens = (yy >= 60) & (yy < 60 + 8 * thick)
    img[lens] *= 0.45
    return u8(img), crack, lens


def test_a_crack_blurred_as_wide_as_a_shadow_is_still_not_shade() -> None:
    """At the fine scale the 3 px crack reads as 6-7 px of shade and survives the opening;
    at its own scale no disc fits in it. The lens holds one, so it stays shade out to the tips
    of its tapers, where it is as thin as the crack."""
    img, crack, lens = crack_and_overcast_lens()
    shade = shadow_likelihood(img, DEFAULT)
    xx = np.mgrid[:120, :240][1]
    tapers = lens & ((xx < 145) | (xx > 215))
    assert shade[crack].mean() < 0.3
    assert shade[lens].mean() > 0.75
    assert shade[tapers].mean() > 0.6


@pytest.mark.parametrize("seed", range(3))
def test_the_default_profile_finds_a_crack_beside_an_overcast_shadow(seed: int) -> None:
    img, crack, _ = crack_and_overcast_lens(seed)
    top = analyze(img, DEFAULT).points[0]
    yy, xx = np.nonzero(crack)
    assert np.hypot(yy - top.y, xx - top.x).min() < 4, (top.x, top.y)


def test_a_wide_ledge_shadow_is_shade_and_a_round_hollow_is_not() -> None:
    """Shade thicker than the surround (a ledge's shadow seen from 60 m) is found at the
    second scale where it runs along its ledge; a round hollow in the same shade, the
    shadowed core of a stain seen close up, is left to the interest."""
    img = rock(RED_ROCK, shape=(240, 400))
    img[40:80, 20:380] *= SKY_SHADE  # a ledge shadow 40 px thick
    yy, xx = np.mgrid[:240, :400]
    img[(yy - 170) ** 2 + (xx - 200) ** 2 <= 22**2] *= SKY_SHADE  # a hollow 44 px across
    shade = shadow_likelihood(u8(img), DEFAULT)
    assert shade[50:70, 60:340].mean() > 0.8
    assert shade[165:175, 195:205].mean() < 0.1  # its middle: the fine scale takes its rim


def test_the_default_profile_finds_a_dark_crack_on_red_rock() -> None:
    img = rock(RED_ROCK, seed=3)
    img[40:54, 40:68] *= SKY_SHADE  # a short ledge shadow, a decoy
    yy, xx = np.mgrid[:120, :200]
    crack = (np.abs(yy - (0.5 * xx + 10)) < 1.0) & (xx > 120) & (xx < 180)
    img[crack] *= 0.3
    top = analyze(u8(img), DEFAULT).points[0]
    near = np.hypot(yy[crack] - top.y, xx[crack] - top.x).min()
    assert near < 4, (top.x, top.y)


def ledge_and_stain() -> tuple[np.ndarray, np.ndarray]:
    """A ledge shadow short enough to pass as a blob, and a smaller wet stain."""
    img = rock(RED_ROCK)
    img[40:54, 40:68] *= SKY_SHADE
    yy, xx = np.mgrid[:120, :200]
    stain = (yy - 85) ** 2 + (xx - 140) ** 2 < 5**2
    wet(img, stain)
    return u8(img), stain


def test_the_gate_takes_a_short_ledge_shadow_off_the_top() -> None:
    img, stain = ledge_and_stain()
    for params, on_stain in ((DEFAULT.replace(shadow_gate=0.0), False), (DEFAULT, True)):
        top = analyze(img, params).points[0]
        assert bool(stain[round(top.y), round(top.x)]) is on_stain
    assert UNCOMMON.shadow_gate == 0.0  # the seed's maps and the fastest profile: no gate


def test_a_point_in_shade_says_so() -> None:
    """A weak gate leaves the shadow on top; its line says it is probably shade, the
    stain's does not."""
    img, stain = ledge_and_stain()
    res = analyze(img, DEFAULT.replace(shadow_gate=0.05))
    assert [bool(stain[round(p.y), round(p.x)]) for p in res.points[:2]] == [False, True]
    shade = [next(e for e in expl if e["plane"] == "shade") for expl in res.explanations]
    assert shade[0]["likelihood"] > 0.5 > shade[1]["likelihood"]
    assert res.descriptions[0].endswith("; probably in shade")
    assert "shade" not in res.descriptions[1]


@pytest.mark.parametrize(
    "bad",
    [
        {"shadow_gate": 1.5},
        {"shadow_gate": -0.1},
        {"shadow_surround": 0.0},
        {"shadow_tint": (0.0, 0.0)},
        {"shadow_tint": (float("nan"), 0.1)},
        {"shadow_tint": (0.3,)},
    ],
)
def test_bad_shadow_parameters_are_refused(bad: dict) -> None:
    with pytest.raises(ValueError, match="shadow"):
        VisionParams(**bad)


def test_a_shadow_of_a_few_pixels_is_scored() -> None:
    """A few dark candidate pixels only: OpenCV must not read them as a scalar (a crash
    once the second scale's copy of a small image had that few)."""
    for width, seed in ((w, k) for w in range(1, 7) for k in range(3)):  # 0 to a few
        img = rock(RED_ROCK, shape=(30, 40), seed=seed)
        img[15, 20 : 20 + width] *= SKY_SHADE
        shade = shadow_likelihood(u8(img), DEFAULT)
        assert shade.shape == (30, 40) and np.isfinite(shade).all()


def test_a_pure_darkening_shifts_no_colour() -> None:
    """Log colour is taken of the value + 8, so halving a red rock also greys its log
    colour (0.07 towards blue): the host is darkened the same way before comparing, and a
    pure darkening of coloured rock is untinted shade, with no sky tint."""
    red = np.float32([[[60, 80, 150]]])
    host = np.log(red + 8.0).astype(np.float32)
    u = tuple(np.array(DEFAULT.shadow_tint) / np.hypot(*DEFAULT.shadow_tint))

    def along(logs: np.ndarray) -> float:  # log(B / R), log(G / R) along the illuminant line
        return float(
            (logs[0, 0, 0] - logs[0, 0, 2]) * u[0] + (logs[0, 0, 1] - logs[0, 0, 2]) * u[1]
        )

    for k in (0.8, 0.5, 0.3):
        own = np.log(red * k + 8.0).astype(np.float32)
        tinted, untinted = _shade(own, host, DEFAULT.shadow_tint, 1)
        assert float(tinted[0, 0]) < 1e-3 and float(untinted[0, 0]) > 0.4, k
    assert along(own) - along(host) > 0.05  # what the plain comparison read as sky shade


def test_a_stain_with_its_colour_barely_deepened_is_not_shade() -> None:
    """A wet stain 20 px across whose colour deepens by only 1.3 on grey-blue rock: its
    middle is most of its own surroundings, and the rock it is compared with must be the
    rock around it, not a mixture with the stain (which made it half shade)."""
    host = (150, 168, 180)
    img = rock(host)
    mask = np.zeros(img.shape[:2], bool)
    mask[50:70, 90:110] = True
    grey = img[mask].mean(axis=1, keepdims=True)
    img[mask] = (grey + (img[mask] - grey) * 1.3) * 0.5
    img[10:18, 20:180] *= 0.45  # overcast shade on the same rock stays shade
    shade = shadow_likelihood(u8(img), DEFAULT)
    assert shade[mask].mean() < 0.15
    assert shade[12:16, 30:170].mean() > 0.8
