"""Memory across stations: a colour no earlier station showed is new, one it showed is not;
the coarse station's interest and the chosen target weigh the close station's points."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from cyborg.daemon.pointing.geometry import CameraModel, MosaicGeometry
from cyborg.daemon.survey.memory import (
    DISTINCT,
    SessionMemory,
    distinctness,
    lab_image,
    station_prior,
)
from cyborg.daemon.survey.register import Frame
from cyborg.daemon.vision.params import DEFAULT
from cyborg.daemon.vision.pipeline import analyze


def test_a_chain_of_walks_places_each_station_in_every_earlier_one() -> None:
    """Known answer: walking 300 -> 60 m (5 times closer) towards (4, -2), then 60 -> 10 m
    (6 times) towards (5, -1) as the 60 m station saw it: the 10 m view's direction d is
    where the 60 m station saw 5 + (d - 5) / 6, and the 300 m one saw that again divided by 5
    about (4, -2); a station shot again without a new aim stands where the last one stood."""
    first = Frame()
    sixty = first.walked((4.0, -2.0), 5.0)
    ten = sixty.walked((5.0, -1.0), 6.0)
    at_60 = (5.0 + (11.0 - 5.0) / 6, -1.0 + (2.0 + 1.0) / 6)
    at_300 = (4.0 + (at_60[0] - 4.0) / 5, -2.0 + (at_60[1] + 2.0) / 5)
    assert ten.into(sixty, 11.0, 2.0) == pytest.approx(at_60)
    assert ten.into(first, 11.0, 2.0) == pytest.approx(at_300)
    assert first.into(ten, *at_300) == pytest.approx((11.0, 2.0))
    assert (ten.scale, first.walked((9.0, 9.0), 1.0)) == (pytest.approx(1 / 30), first)


def test_distinct_is_the_core_against_its_surround_at_each_scale() -> None:
    """Known answer: a plain rock shows nothing; a green disc on it stands out by the colour
    difference of disc and rock; seen five times further (each pixel the mean of 5 x 5), the
    same angular patch is a fifth as many pixels and still distinct; a speck a pixel across
    averages into the rock from afar."""
    rock, plant = (110, 140, 170), (40, 170, 40)
    img = np.full((200, 200, 3), rock, np.uint8)
    assert distinctness(lab_image(img), 100, 100, 10) == pytest.approx(0.0, abs=1e-3)
    ys, xs = np.mgrid[0:200, 0:200]
    img[np.hypot(xs - 100, ys - 100) <= 10] = plant
    img[50, 50] = plant
    swatch = lab_image(np.array([[rock, plant]], np.uint8))[0]
    delta = float(np.linalg.norm(swatch[1] - swatch[0]))
    assert distinctness(lab_image(img), 100, 100, 10) == pytest.approx(delta, rel=1e-3)
    far = cv2.resize(img, (40, 40), interpolation=cv2.INTER_AREA)
    assert distinctness(lab_image(far), 19.5, 19.5, 2) > 0.5 * delta
    assert distinctness(lab_image(far), 9.5, 9.5, 0.2) < DISTINCT < 0.5 * delta


def _two_spots(left: int, right: int) -> np.ndarray:
    """A 2-tile mosaic of buff rock (360 x 144) with a dark spot in each tile."""
    rng = np.random.default_rng(5)
    img = np.clip(rng.normal((110, 140, 170), 3, (144, 360, 3)), 0, 255).astype(np.uint8)
    img[72 - left : 72 + left, 90 - left : 90 + left] = (30, 40, 50)
    img[72 - right : 72 + right, 270 - right : 270 + right] = (30, 40, 50)
    return img


def test_memory_de_emphasises_what_was_common_from_afar() -> None:
    """Known answer: the right spot is the bigger one, so alone it comes first; but the
    station this one was aimed from judged the left half interesting and the right common,
    so with memory the left spot comes first. Away from the chosen target (here the middle of
    the mosaic), ground judged interesting keeps a quarter of the favour: 1 - 0.8 + 0.8 / 4."""
    geo = MosaicGeometry(CameraModel(720, 576, 30.0), 1, 2, downsample=4)
    earlier = np.zeros((144, 360), np.uint8)
    earlier[:, :180] = 200  # the coarse look's interest: high on the left, nil on the right
    plain = analyze(_two_spots(6, 8), DEFAULT)
    assert plain.points[0].x > 180
    prior = station_prior(
        earlier, geo, geo, target=(0.0, 0.0), radius_deg=0.0, walk=1.0, weight=0.8
    )
    assert prior.min() == pytest.approx(0.2, abs=0.01) and prior.max() <= 1.0
    scale = prior.shape[1] / 360
    assert prior[int(72 * scale), int(90 * scale)] == pytest.approx(0.4, abs=0.01)
    assert prior[int(72 * scale), int(270 * scale)] == pytest.approx(0.2, abs=0.01)
    remembered = analyze(_two_spots(6, 8), DEFAULT, prior)
    assert remembered.points[0].x < 180
    # Patches keep their extent from the unweighted map: the spots are the same size.
    assert remembered.points[0].radius == pytest.approx(plain.points[1].radius, rel=0.2)


def test_memory_favours_the_chosen_targets_surroundings() -> None:
    geo = MosaicGeometry(CameraModel(720, 576, 30.0), 1, 2, downsample=4)
    nothing = np.zeros((144, 360), np.uint8)  # the earlier look saw all of it as common
    left = geo.to_angles(90, 72)
    prior = station_prior(nothing, geo, geo, target=left, radius_deg=1.0, walk=1.0, weight=0.8)
    assert analyze(_two_spots(6, 8), DEFAULT, prior).points[0].x < 180


def test_the_favoured_neighbourhood_is_where_the_target_was_placed() -> None:
    """Known answer: with nothing judged interesting from afar, the weight is 1 where the
    earlier station placed the chosen target and falls as a Gaussian of half its radius
    (sigma 0.5 x 6 = 3 deg), to 1 - weight around it: one sigma off 0.5 + 0.5 e^-0.5, four
    off 0.5."""
    geo = MosaicGeometry(CameraModel(720, 576, 30.0), 1, 2, downsample=4)
    left = geo.to_angles(90, 72)
    prior = station_prior(
        np.zeros((144, 360), np.uint8), geo, geo, target=left, radius_deg=6.0, walk=1.0, weight=0.5
    )
    scale = prior.shape[1] / 360

    def at(pan: float, tilt: float) -> float:
        x, y = geo.to_mosaic(pan, tilt)
        return float(prior[int(y * scale), int(x * scale)])

    assert at(*left) == pytest.approx(1.0, abs=0.02)
    assert at(left[0] + 3.0, left[1]) == pytest.approx(0.5 + 0.5 * math.exp(-0.5), abs=0.04)
    assert at(left[0] + 12.0, left[1]) == pytest.approx(0.5, abs=0.01)


def test_the_target_is_favoured_on_a_seam() -> None:
    """The survey aims each station at the chosen target, so in a mosaic of two rows the
    target lies on the seam between them (here the 10 m station of a field run, zoomed to
    1.02 deg): the favour is whole there, not lost to a rounding error."""
    geo = MosaicGeometry(CameraModel(720, 576, 1.0234633086100724), 2, 3, -4.6276, 1.5409, 4)
    nothing = np.zeros((288, 540), np.uint8)
    prior = station_prior(
        nothing, geo, geo, target=(-4.6276, 1.5409), radius_deg=1.81, walk=1.0, weight=0.8
    )
    rows, cols = prior.shape
    assert prior[rows // 2, cols // 2] == pytest.approx(1.0, abs=0.01)
    assert prior[rows // 2, 0] < 0.7  # 1.5 deg off: e^(-1.5^2 / (2 x 0.9^2)) = 0.25 of it


def test_a_prior_must_be_a_finite_map() -> None:
    with pytest.raises(ValueError, match="finite 2-D map"):
        analyze(_two_spots(6, 8), DEFAULT, np.full((4, 4), np.nan, np.float32))


def test_memory_de_emphasises_colours_common_from_afar() -> None:
    """Known answer: everything was judged interesting from afar and no target is near, so
    each cell keeps a quarter of the favour times how new its colour is: the dark spot and
    the buff rock were main colours of the earlier station (1 - 0.8 + 0.8 x 0.25 x ~0), the
    green plant was not (ΔE > 20: 1 - 0.8 + 0.8 x 0.25)."""
    geo = MosaicGeometry(CameraModel(720, 576, 30.0), 1, 2, downsample=4)
    earlier = _two_spots(30, 30)  # buff rock and large dark patches: both main colours
    memory = SessionMemory()
    memory.remember("s/st01-300m", earlier, geo, [], None)
    now = _two_spots(12, 12)
    now[60:84, 258:282] = (40, 170, 40)  # the right spot is a plant nobody saw from afar
    prior = station_prior(
        np.full((144, 360), 200, np.uint8),
        geo,
        geo,
        target=(90.0, 0.0),  # far outside the mosaic
        radius_deg=1.0,
        walk=1.0,
        weight=0.8,
        mosaic=now,
        palettes=memory.palettes(),
    )
    scale = prior.shape[1] / 360
    assert prior[int(72 * scale), int(90 * scale)] == pytest.approx(0.2, abs=0.02)  # dark spot
    assert prior[int(20 * scale), int(180 * scale)] == pytest.approx(0.2, abs=0.02)  # buff rock
    assert prior[int(72 * scale), int(270 * scale)] == pytest.approx(0.4, abs=0.01)  # the plant
