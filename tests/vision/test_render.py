"""The pictures a reader sees: class colours that colour-blind readers tell apart, a scale
on every stand-alone map, no ring on a point that is no further target."""

from __future__ import annotations

import itertools
from pathlib import Path

import cv2
import numpy as np
import pytest

from cyborg.daemon.sim.scene import outcrop_scene
from cyborg.daemon.vision import render
from cyborg.daemon.vision.cooccurrence import PlaneClass, Segmentation
from cyborg.daemon.vision.interest import InterestPoint
from cyborg.daemon.vision.job import analyze_image, write_products
from cyborg.daemon.vision.params import DEFAULT
from cyborg.protocol.palette import CLASS_RGB, UNSEGMENTED_RGB, bgr

# Machado, Oliveira & Fernandes (2009), full severity, on linear RGB.
_DEFICIENCIES = {
    "protanopia": [[0.152, 1.053, -0.205], [0.115, 0.786, 0.099], [-0.004, -0.048, 1.052]],
    "deuteranopia": [[0.367, 0.861, -0.228], [0.280, 0.673, 0.047], [-0.012, 0.043, 0.969]],
    "tritanopia": [[1.256, -0.077, -0.179], [-0.078, 0.931, 0.148], [0.005, 0.691, 0.304]],
}
_CLEARLY_APART = 12.0
"""CIE76 distance two class colours keep as a colour-blind reader sees them (the old
palette's red and green classes came to 9, its green and orange to 4)."""


def _seen(rgb: np.ndarray, matrix: list[list[float]]) -> np.ndarray:
    """sRGB 0..255 as a reader with this deficiency sees it, in CIE Lab."""
    c = rgb / 255.0
    linear = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    sim = np.clip(linear @ np.asarray(matrix).T, 0.0, 1.0)
    srgb = np.where(sim <= 0.0031308, 12.92 * sim, 1.055 * sim ** (1 / 2.4) - 0.055)
    return cv2.cvtColor(srgb.astype(np.float32)[None], cv2.COLOR_RGB2Lab)[0]


@pytest.mark.parametrize("deficiency", sorted(_DEFICIENCIES))
def test_class_colours_stay_apart_for_colour_blind_readers(deficiency: str) -> None:
    lab = _seen(np.array([*CLASS_RGB, UNSEGMENTED_RGB], float), _DEFICIENCIES[deficiency])
    closest = min(np.linalg.norm(a - b) for a, b in itertools.combinations(lab, 2))
    assert closest >= _CLEARLY_APART


@pytest.fixture(scope="module")
def products(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("analysis")
    bgr, res = analyze_image(outcrop_scene(3).image, DEFAULT)
    write_products(folder, "scene", bgr, res, "default")
    return folder


@pytest.mark.parametrize(
    ("figure", "data"),
    [
        *((f"figure_segmentation_{c}.png", f"segmentation_{c}.png") for c in "hsi"),
        *((f"figure_uncommon_{c}.png", f"uncommon_{c}.png") for c in "hsi"),
        ("figure_interest.png", "interest.png"),
    ],
)
def test_every_stand_alone_map_carries_its_scale(products: Path, figure: str, data: str) -> None:
    fig = cv2.imread(str(products / figure), cv2.IMREAD_COLOR)
    raw = cv2.imread(str(products / data), cv2.IMREAD_UNCHANGED)
    assert fig.shape[0] > raw.shape[0] and fig.shape[1] > raw.shape[1]  # room for axes, legend
    ink = np.all(fig < 80, axis=2)
    left = ink[:, :40].any()  # tick labels left of the map
    assert left and ink[-40:].any()  # and below it
    if figure.startswith("figure_segmentation"):  # its legend: test_a_class_map_names
        return
    ramp = cv2.applyColorMap(np.array([[0, 255]], np.uint8), cv2.COLORMAP_VIRIDIS)[0]
    for end in ramp:  # a colour bar from viridis' darkest to its brightest
        assert np.all(fig == end, axis=2).any()


def test_a_class_map_names_every_class_colour_and_the_unsegmented() -> None:
    labels = np.ones((30, 40), np.uint8)  # all class 1: the others appear in the legend only
    classes = tuple(PlaneClass(center=40 * k, radius=10, height=1.0) for k in range(1, 9))
    fig = render.class_figure(Segmentation(labels, classes, np.zeros((256, 256))), "H")
    for colour in (*render.CLASS_COLOURS, bgr(UNSEGMENTED_RGB)):
        assert np.all(fig == colour, axis=2).sum() >= 12 * 12


def test_the_cooccurrence_plot_has_axes_a_colour_bar_and_its_classes(products: Path) -> None:
    plot = cv2.imread(str(products / "cooccurrence_i.png"), cv2.IMREAD_COLOR)
    assert plot.shape[0] > 512 and plot.shape[1] > 512
    for k in range(1, 3):  # the boxes and their swatches in the legend
        assert np.all(plot == render.CLASS_COLOURS[k - 1], axis=2).sum() > 14 * 14


def test_a_point_that_is_no_further_target_gets_no_ring() -> None:
    image = np.full((60, 80, 3), 128, np.uint8)
    background = InterestPoint(2, 40.0, 30.0, 0.02, 5.0, target=False)
    assert np.array_equal(render.overlay(image, [background]), image)
    assert not np.array_equal(
        render.overlay(image, [InterestPoint(1, 40.0, 30.0, 4.0, 5.0)]), image
    )
