"""An overlapping station covers the field a butted one would: the approach's fitted mosaic
gets the tiles its shorter steps need, the canvas's crop margin stays a small share of a
long lens's frame, and a station's map carried through the spherical geometry lands where
it was."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from cyborg.daemon.config import SurveyConfig
from cyborg.daemon.pointing.geometry import (
    CROP_MARGIN_DEG,
    CROP_MARGIN_SHARE,
    CameraModel,
    MosaicGeometry,
    SphericalMosaic,
)
from cyborg.daemon.survey.approach import Approach
from cyborg.daemon.survey.register import carry
from cyborg.protocol.messages import InterestPoint, SurveyStart

OPTICS = CameraModel(720, 576, 30.0)
SIMULATED = SurveyConfig(simulate_approach=True)


def _station(cfg: SurveyConfig, leg: int, radius: float) -> MosaicGeometry:
    """The geometry of the approach's station ``leg`` (1: 60 m, 2: 10 m), aimed each time at
    a target of ``radius`` degrees at (-9.7, -2.4), as the survey plans it."""
    ap = Approach()
    for at in range(leg):
        point = InterestPoint(1, 100.0, 50.0, 3.0, -9.7, -2.4, radius_deg=radius)
        ap.advance(point, f"s/st0{at + 1}", cfg, OPTICS)
    req = ap.complete(SurveyStart(), cfg)
    return ap.plan(req, (0.0, 0.0), ap.camera(cfg, OPTICS), cfg.overlap)


def _reach(g: MosaicGeometry) -> tuple[tuple[float, float], tuple[float, float]]:
    """(pan, tilt) ranges a mosaic's pixels show: its canvas's, or its frames' butted."""
    if not isinstance(g, SphericalMosaic):
        return g.extent
    (p0, t1), (p1, t0) = g.to_angles(0, 0), g.to_angles(*g.size)
    return (p0, p1), (t0, t1)


@pytest.mark.parametrize("overlap", [0.2, 0.3, 0.5])
@pytest.mark.parametrize(("leg", "radius"), [(1, 1.0), (1, 4.0), (2, 0.2), (2, 1.0)])
def test_an_overlapping_station_covers_what_a_butted_one_would(
    overlap: float, leg: int, radius: float
) -> None:
    """At 0.3 the 10 m station's 2×3 canvas showed ±0.7° × ±0.2° of the butted ±1.5° × ±0.8°
    (the margin a fixed 0.5°, the tiles as many as butted) and the stain's core fell outside
    it. Now every edge lies at most the crop margin inside the butted field's."""
    butted = _station(SIMULATED, leg, radius)
    overlapping = _station(replace(SIMULATED, overlap=overlap), leg, radius)
    assert isinstance(overlapping, SphericalMosaic) and not isinstance(butted, SphericalMosaic)
    assert overlapping.rows >= butted.rows and overlapping.cols >= butted.cols
    margin = min(CROP_MARGIN_DEG, CROP_MARGIN_SHARE * butted.camera.vfov)
    slack = margin + 0.01 * butted.camera.hfov  # and a frame's bowed edge
    for (lo, hi), (butted_lo, butted_hi) in zip(_reach(overlapping), _reach(butted), strict=True):
        assert lo <= butted_lo + slack and hi >= butted_hi - slack


def test_paper_and_an_asked_for_mosaic_keep_their_tiles() -> None:
    """``paper`` butts whatever the overlap; rows × cols asked for are the tiles shot."""
    cfg = replace(SIMULATED, overlap=0.3)
    ap = Approach()
    ap.advance(InterestPoint(1, 1.0, 1.0, 3.0, 0.0, 0.0, radius_deg=4.0), "s/st01", cfg, OPTICS)
    fields = ap.mosaic
    assert fields is not None
    paper = ap.complete(SurveyStart(profile="paper"), cfg)
    assert (paper.rows, paper.cols) == fields
    assert ap.plan(paper, (0.0, 0.0), OPTICS, cfg.overlap) == MosaicGeometry(
        OPTICS, *fields, 0.0, 0.0, cfg.downsample
    )
    asked = ap.complete(SurveyStart(rows=2, cols=3), cfg)
    assert (asked.rows, asked.cols) == (2, 3)


def test_a_map_carried_through_a_spherical_mosaic_lands_where_it_was() -> None:
    """Carrying a station's map into its own frame (no walk) through ``to_angles`` and
    ``to_mosaic`` is the identity on the canvas: no butted pixel layout is assumed."""
    g = SphericalMosaic(OPTICS.zoomed(30.0), 3, 4, -9.7, -2.4, 12.0, overlap=0.3)
    width, height = g.size
    plane = np.arange(width * height, dtype=np.float32).reshape(height, width)
    carried = carry(plane, g, g, target=(g.pan0, g.tilt0), walk=1.0, size=g.size)
    inner = np.s_[: height - 1, : width - 1]  # carry samples strictly inside the map
    np.testing.assert_array_equal(carried[inner], plane[inner])
