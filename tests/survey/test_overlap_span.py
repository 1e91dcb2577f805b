"""A configured (unaimed) overlapping station spans exactly the field its butted plan would
(per-axis steps stretch its tiles across the fields; aimed ones are ``test_overlap_field``'s),
and the operator hears the tiles the plan will shoot."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from cyborg.daemon.config import SurveyConfig
from cyborg.daemon.pointing.geometry import CameraModel, MosaicGeometry, SphericalMosaic
from cyborg.daemon.survey.approach import Approach, advice
from cyborg.protocol.messages import InterestPoint, SurveyStart

OPTICS = CameraModel(720, 576, 30.0)
SIMULATED = SurveyConfig(simulate_approach=True)
TARGET = InterestPoint(1, 100.0, 50.0, 3.0, -9.7, -2.4, radius_deg=1.5)


def _first_station(cfg: SurveyConfig) -> MosaicGeometry:
    """A session's first station as the survey plans it: the configured mosaic."""
    ap = Approach()
    return ap.plan(ap.complete(SurveyStart(), cfg), (4.0, -2.0), OPTICS, cfg.overlap)


@pytest.mark.parametrize("overlap", [0.2, 0.3, 0.5])
@pytest.mark.parametrize(("rows", "cols"), [(2, 3), (1, 4), (3, 2)])
def test_the_configured_station_spans_the_butted_field(
    overlap: float, rows: int, cols: int
) -> None:
    """At 0.3 a configured 2×3 plan shot 2×3 tiles 0.7 of a field apart: 1.7 × 2.4 fields.
    Now its outermost frames are the butted plan's, and no neighbours overlap by less than
    asked."""
    cfg = replace(SIMULATED, rows=rows, cols=cols)
    butted = _first_station(cfg)
    overlapping = _first_station(replace(cfg, overlap=overlap))
    assert isinstance(overlapping, SphericalMosaic)
    assert (overlapping.rows, overlapping.cols) == (
        SphericalMosaic.tiles(rows, overlap),
        SphericalMosaic.tiles(cols, overlap),
    )
    for got, want in zip(overlapping.extent, butted.extent, strict=True):
        assert got == pytest.approx(want, abs=1e-9)
    assert overlapping.step_pan <= OPTICS.hfov * (1 - overlap) + 1e-9
    assert overlapping.step_tilt <= OPTICS.vfov * (1 - overlap) + 1e-9


def test_asked_for_tiles_keep_the_plain_step() -> None:
    """Rows × cols asked for are the tiles shot, ``1 - overlap`` of a field apart, per axis:
    an unasked axis still spans its configured fields."""
    cfg = replace(SIMULATED, overlap=0.3)
    ap = Approach()
    g = ap.plan(ap.complete(SurveyStart(rows=2), cfg), (0.0, 0.0), OPTICS, cfg.overlap)
    assert (g.rows, g.cols) == (2, 4)
    assert g.step_tilt == pytest.approx(0.7 * OPTICS.vfov)
    assert g.step_pan == pytest.approx(OPTICS.hfov * 2 / 3)


def test_the_plan_records_its_steps() -> None:
    """The archived plan (through JSON) gives back the very tiles shot, so every later
    station, memory and the chips read the mosaic where it was painted."""
    g = _first_station(replace(SIMULATED, overlap=0.3))
    back = MosaicGeometry.from_plan(json.loads(json.dumps(g.to_plan(profile="default"))))
    assert back == g
    assert [back.tile_pose(r, c) for r, c in back.serpentine()] == [
        g.tile_pose(r, c) for r, c in g.serpentine()
    ]


@pytest.mark.parametrize("overlap", [0.0, 0.3])
def test_the_advice_names_the_tiles_the_plan_shoots(overlap: float) -> None:
    """The operator heard "a 2×3 mosaic" while the plan shot 3×4 tiles."""
    cfg = replace(SIMULATED, overlap=overlap)
    ap = Approach()
    fit = ap.advance(TARGET, "s/st01", cfg, OPTICS)
    said = advice(TARGET, json.loads(json.dumps(fit)))  # as the manifest keeps it, too
    g = ap.plan(ap.complete(SurveyStart(), cfg), (0.0, 0.0), ap.camera(cfg, OPTICS), overlap)
    assert f": a {g.rows}×{g.cols} mosaic" in said
    assert (f"across {fit['rows']}×{fit['cols']} fields of view" in said) == (overlap > 0)
