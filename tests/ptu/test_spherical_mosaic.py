"""The overlapping, projected mosaic's geometry: the interface the butted one has (plan round
trip, pixel <-> angles both ways), the seed's butting untouched, ``paper`` always butted."""

from __future__ import annotations

import numpy as np
import pytest

from cyborg.daemon.pointing.geometry import CameraModel, MosaicGeometry, SphericalMosaic
from cyborg.daemon.survey.approach import Approach
from cyborg.protocol.messages import SurveyStart

CAM = CameraModel(720, 576, 30.0)


def test_plan_round_trip_picks_the_projection() -> None:
    butted = MosaicGeometry(CAM, 2, 3, 4.0, -2.0, 4.0)
    assert butted.overlapping(0.0) is butted
    plan = butted.to_plan(profile="paper")
    assert "overlap" not in plan and type(MosaicGeometry.from_plan(plan)) is MosaicGeometry
    g = butted.overlapping(0.3)
    plan = g.to_plan(profile="default")
    assert plan["projection"] == "spherical" and plan["mosaic"]["width"] == g.size[0]
    assert MosaicGeometry.from_plan(plan) == g and isinstance(g, SphericalMosaic)
    with pytest.raises(ValueError, match="overlap"):
        butted.overlapping(0.7)


def test_tiles_overlap_and_pixels_map_both_ways() -> None:
    g = SphericalMosaic(CAM, 3, 4, pan0=10.0, tilt0=-5.0, downsample=4, overlap=0.3)
    (p0, t0), (p1, _), (_, t1) = g.tile_pose(0, 0), g.tile_pose(0, 1), g.tile_pose(1, 0)
    assert (p1 - p0, t0 - t1) == pytest.approx((0.7 * CAM.hfov, 0.7 * CAM.vfov))
    width, height = g.size
    for row, col in g.serpentine():  # every tile's centre is on the canvas, where it points
        mx, my = g.to_mosaic(*g.tile_pose(row, col))
        assert 0 < mx < width and 0 < my < height
        assert g.to_angles(mx, my) == pytest.approx(g.tile_pose(row, col), abs=1e-9)
    for mx, my in [(width / 5, 30.25), (width / 2, height / 2), (width - 30.0, height - 26.0)]:
        assert g.to_mosaic(*g.to_angles(mx, my)) == pytest.approx((mx, my), abs=1e-6)
        assert g.pixel_angles(mx - 0.5, my - 0.5) == g.to_angles(mx, my)
    assert g.to_mosaic(170.0, 0.0) is None


def test_the_canvas_is_cropped_to_what_every_planned_tile_covers() -> None:
    """No corner of the canvas is left for no frame (a sliver the science would take for a
    black step), and the crop keeps nearly all the extent."""
    g = SphericalMosaic(CAM, 2, 3, pan0=10.0, tilt0=20.0, downsample=4, overlap=0.3)
    width, height = g.size
    (a0, a1), (b0, b1) = g.extent
    for mx in np.linspace(0.5, width - 0.5, 40):
        for my in (0.5, height / 2, height - 0.5):
            assert g.to_mosaic(*g.to_angles(mx, my)) is not None
    for my in np.linspace(0.5, height - 0.5, 40):
        for mx in (0.5, width - 0.5):
            pan, tilt = g.to_angles(mx, my)
            assert a0 < pan < a1 and b0 < tilt < b1 and g.to_mosaic(pan, tilt) is not None
    kept = width * height * g.degrees_per_pixel**2 / ((a1 - a0) * (b1 - b0))
    assert 0.8 < kept < 1.0


def test_paper_keeps_the_seeds_butting() -> None:
    ap, req = Approach(), SurveyStart(rows=2, cols=3, downsample=4.0, profile="paper")
    assert type(ap.plan(req, (0.0, 0.0), CAM, 0.3)) is MosaicGeometry
    req = SurveyStart(rows=2, cols=3, downsample=4.0, profile="default")
    assert ap.plan(req, (0.0, 0.0), CAM, 0.3).overlap == 0.3
    assert type(ap.plan(req, (0.0, 0.0), CAM)) is MosaicGeometry
