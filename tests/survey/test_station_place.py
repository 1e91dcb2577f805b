"""Where each station stood: a fix wins; else the session's first station stands at the
configured site and each later one is dead-reckoned along the walked leg (the chosen
target's azimuth, the distance walked), and stays put when the lens zoomed instead. Each
point's target is estimated at the station's range along its azimuth and elevation."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from cyborg.daemon.archive import Archive
from cyborg.daemon.config import SurveyConfig
from cyborg.daemon.survey.approach import Approach
from cyborg.daemon.survey.site import (
    EARTH_RADIUS_M,
    Leg,
    Orientation,
    SiteConfig,
    locate,
    offset,
    place,
    where,
)
from cyborg.protocol.messages import ChooseTarget, SurveyStart
from tests.survey.test_survey_engine import _engine

SITE = SiteConfig(name="Rivas", latitude=40.331, longitude=-3.517, altitude=612.5, heading=350.0)


def _inverse(a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    """Distance (m) and initial bearing (deg) from a to b: haversine, an independent check."""
    (lat1, lon1), (lat2, lon2) = (map(math.radians, p) for p in (a, b))
    h = (
        math.sin((lat2 - lat1) / 2) ** 2
        + math.cos(lat1) * math.cos(lat2) * math.sin((lon2 - lon1) / 2) ** 2
    )
    distance = 2 * EARTH_RADIUS_M * math.asin(math.sqrt(h))
    y = math.sin(lon2 - lon1) * math.cos(lat2)
    x = math.cos(lat1) * math.sin(lat2) - math.sin(lat1) * math.cos(lat2) * math.cos(lon2 - lon1)
    return distance, math.degrees(math.atan2(y, x)) % 360.0


def _latlon(record: dict) -> tuple[float, float]:
    return record["latitude"], record["longitude"]


@pytest.mark.parametrize("start", [(40.331, -3.517), (-62.2, 179.999), (0.0, 0.0)])
@pytest.mark.parametrize("bearing", [0.0, 37.5, 90.0, 200.0, 349.0])
@pytest.mark.parametrize("distance", [10.0, 240.0, 5000.0])
def test_offset_goes_the_distance_along_the_bearing(start, bearing, distance) -> None:
    got, heading = _inverse(start, offset(*start, bearing, distance))
    assert got == pytest.approx(distance, abs=0.02)  # 7 decimals of a degree: ~1 cm
    assert heading == pytest.approx(bearing, abs=0.01 if distance > 100 else 0.1)


def test_a_station_is_placed_by_a_fix_else_the_site_else_the_walk() -> None:
    first = where(SITE, None)
    assert first["source"] == "config" and _latlon(first) == (40.331, -3.517)
    assert place(first, None, None) is first  # a session's first station: the site
    fix = first | {"latitude": 40.4, "longitude": -3.6, "source": "gpsd 127.0.0.1:2947"}
    assert place(fix, first, Leg("st01-300m", 90.0, 240.0)) is fix  # a fresh fix wins

    walked = place(where(SITE, None), first, Leg("st01-300m", 120.0, 240.0))
    assert walked["source"] == "dead-reckoned" and walked["altitude"] is None
    assert walked["leg"] == {"from": "st01-300m", "bearing_deg": 120.0, "distance_m": 240.0}
    distance, bearing = _inverse(_latlon(first), _latlon(walked))
    assert (distance, bearing) == (pytest.approx(240.0, abs=0.02), pytest.approx(120.0, abs=0.01))
    assert (walked["name"], walked["heading"]) == ("Rivas", 350.0)  # the site's, as before

    again = place(where(SITE, None), walked, Leg("st02-60m", None, 0.0))  # it stayed
    assert {k: again[k] for k in ("latitude", "longitude", "source", "leg")} == {
        k: walked[k] for k in ("latitude", "longitude", "source", "leg")
    }
    blind = place(where(SITE, None), first, Leg("st01-300m", None, 240.0))  # no heading
    assert blind["source"] == "unknown" and blind["latitude"] is None


def test_a_zooming_approach_stands_where_it_started(tmp_path: Path) -> None:
    """Intelligent zoom narrows the lens from the tripod: the next station is where the
    first stood. A simulated approach stands for a walk: it is dead-reckoned."""
    archive = Archive(tmp_path / "archive", "t")
    archive.open()
    session = archive.new_session()
    archive.new_station(session, 1, 300.0, site=where(SITE, None))
    aimed = Approach(session, 1, 1, (2.0, -1.0), f"{session}/st01-300m#1", 0.5, 80.0)
    zoom = aimed.place(SurveyConfig(zoom_on_target=True), archive, where(SITE, None), "")
    assert zoom["source"] == "config" and _latlon(zoom) == _latlon(where(SITE, None))
    assert aimed.range(SurveyConfig(zoom_on_target=True)) == 300.0
    walk = aimed.place(SurveyConfig(simulate_approach=True), archive, where(SITE, None), "")
    assert walk["source"] == "dead-reckoned" and walk["leg"]["distance_m"] == 240.0
    assert aimed.range(SurveyConfig(simulate_approach=True)) == 60.0
    unaimed = Approach(session, 1, 1)  # no target chosen: shot again where the last one was
    again = unaimed.place(SurveyConfig(), archive, where(SITE, None), f"{session}/st01-300m")
    assert again["source"] == "config" and _latlon(again) == _latlon(where(SITE, None))


def test_located_targets_lie_at_the_range_along_azimuth_and_elevation() -> None:
    station = where(SITE, None)
    points = [{"rank": 1, "azimuth": 10.0, "elevation": 20.0}, {"rank": 2, "azimuth": None}]
    near, unaimed = locate(points, station, 60.0)
    position = near["position"]
    distance, bearing = _inverse(_latlon(station), _latlon(position))
    assert distance == pytest.approx(60.0 * math.cos(math.radians(20.0)), abs=0.02)
    assert bearing == pytest.approx(10.0, abs=0.05)
    up = 60.0 * math.sin(math.radians(20.0))
    assert position["altitude"] == pytest.approx(612.5 + up, abs=0.005)  # to the centimetre
    assert (position["range_m"], position["estimated"]) == (60.0, True)
    assert "position" not in unaimed and "position" not in points[0]  # input untouched
    assert locate(points, where(SiteConfig(), None), 60.0) == points  # nowhere: no estimate


async def test_three_stations_walked_are_placed_along_the_walk(tmp_path: Path) -> None:
    """300 -> 60 -> 10 m with a site and no gpsd, through the survey engine: station 2 lies
    240 m from station 1 along the azimuth of the target chosen there, station 3 50 m on
    along the next one; every point's target lies at its station's range."""
    config = SurveyConfig(approach=(300.0, 60.0, 10.0), simulate_approach=True)
    orientation = Orientation(SITE.heading, SITE.level)
    async with _engine(
        tmp_path, config, orientation=orientation, site=lambda: where(SITE, None)
    ) as (survey, _, archive):
        walked = []
        for rank in (2, 1, None):  # the 300 m #2, then the 60 m #1: the chosen one leads
            survey.start(SurveyStart(rows=1, cols=2), "tester")
            await survey._task
            walked.append(survey.station_id)
            if rank is not None:
                await survey.choose(ChooseTarget(survey._result.station, rank), "tester")
        stations = [archive.manifest(s) for s in walked]  # as written on disk
    assert [m["distance_m"] for m in stations] == list(config.approach)
    first, second, third = (m["site"] for m in stations)
    assert first["source"] == "config" and _latlon(first) == (40.331, -3.517)
    for earlier, here, walked in ((stations[0], second, 240.0), (stations[1], third, 50.0)):
        chosen = earlier["points"][earlier["choice"]["rank"] - 1]
        assert here["source"] == "dead-reckoned"
        assert here["leg"] == {
            "from": earlier["station"],
            "bearing_deg": chosen["azimuth"],
            "distance_m": walked,
        }
        distance, bearing = _inverse(_latlon(earlier["site"]), _latlon(here))
        assert distance == pytest.approx(walked, abs=0.02)
        assert bearing == pytest.approx(chosen["azimuth"], abs=0.01)
    for m in stations:
        assert m["points"]
        for p in m["points"]:
            distance, bearing = _inverse(_latlon(m["site"]), _latlon(p["position"]))
            flat = m["distance_m"] * math.cos(math.radians(p["elevation"]))
            assert distance == pytest.approx(flat, abs=0.02)
            assert bearing == pytest.approx(p["azimuth"], abs=0.05)
            assert p["position"]["range_m"] == m["distance_m"] and p["position"]["estimated"]
