"""The approach between stations, in-process: the one look-up of the station a station was
aimed from, how far the view changed since (walked or zoomed), the next mosaic fitted to
the target, and a station's geometry read back from the archive."""

from __future__ import annotations

from pathlib import Path

import pytest

from cyborg.daemon.archive import Archive, ArchiveError
from cyborg.daemon.config import SurveyConfig
from cyborg.daemon.pointing.geometry import CameraModel, MosaicGeometry
from cyborg.daemon.survey import station_geometry
from cyborg.daemon.survey.approach import Approach, Previous, advice
from cyborg.protocol.messages import InterestPoint, SurveyStart

OPTICS = CameraModel(720, 576, 30.0)
TARGET = InterestPoint(1, 100.0, 50.0, 3.0, 4.0, -2.0, radius_deg=0.5)


def test_a_first_station_has_no_previous_one() -> None:
    cfg = SurveyConfig()
    assert Approach().previous(cfg) is None
    ap = Approach()
    ap.advance(TARGET, "s/st01-300m", cfg, OPTICS)
    ap.unaim()  # no target chosen at the next station: nothing to register to
    assert ap.previous(cfg) is None


@pytest.mark.parametrize(
    ("cfg", "walk"),
    [(SurveyConfig(), 5.0), (SurveyConfig(simulate_approach=True), 1.0)],
    ids=["walked", "zoomed"],
)
def test_the_previous_station_is_the_one_aimed_from(cfg: SurveyConfig, walk: float) -> None:
    """Walking 300 -> 60 m spreads directions five times; zooming from the tripod does not."""
    ap = Approach()
    ap.advance(TARGET, "s/st01-300m", cfg, OPTICS)
    assert ap.previous(cfg) == Previous("s/st01-300m", (4.0, -2.0), 0.5, walk)
    assert ap.distance(cfg) == 60.0 and not ap.last_leg(cfg)
    assert ap.magnification(cfg) == (5.0 if cfg.simulate_approach else 1.0)


def test_the_next_mosaic_is_fitted_to_the_target_and_fills_the_request() -> None:
    cfg = SurveyConfig()
    ap = Approach()
    fit = ap.advance(TARGET, "s/st01-300m", cfg, OPTICS)
    assert fit["target_deg"] == pytest.approx(2 * 0.5 * 300 / 60)
    assert fit["suggested_m"] == pytest.approx(300 * 2 * 0.5 / 10.0)
    assert ap.mosaic == (fit["rows"], fit["cols"])
    assert advice(TARGET, fit).endswith(
        f"a {fit['rows']}×{fit['cols']} mosaic (at 30 m it would fill a third of the view)"
    )
    req = ap.complete(SurveyStart(), cfg)
    assert (req.rows, req.cols, req.profile) == (*ap.mosaic, cfg.profile)
    assert ap.complete(SurveyStart(rows=1, cols=1), cfg).rows == 1  # asked for: kept
    # The centre is a decision: asked for, else aimed at, else the one given.
    assert ap.plan(req, (9.0, 9.0), OPTICS).pan0 == 4.0
    assert ap.plan(ap.complete(SurveyStart(pan0=1.0), cfg), (9.0, 9.0), OPTICS).pan0 == 1.0
    assert Approach().plan(req, (9.0, 8.0), OPTICS).tilt0 == 8.0


def test_a_station_s_geometry_is_read_back_from_its_plan(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "a")
    archive.open()
    session = archive.new_session()
    geometry = MosaicGeometry(OPTICS, 2, 3, 5.0, -1.0, 4.0)
    archive.new_station(session, 1, 300.0, plan=geometry.to_plan(profile="default"))
    assert station_geometry(archive, f"{session}/st01-300m") == geometry
    archive.new_station(session, 2, 60.0)  # no plan
    for bad in (f"{session}/st02-60m", f"{session}/st09-1m", "nope/st01-300m"):
        with pytest.raises(ArchiveError, match=f"station {bad}: no usable plan"):
            station_geometry(archive, bad)
