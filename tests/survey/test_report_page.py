"""The session report, rendered in-process from an archive's stations."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from cyborg.daemon.archive import Archive
from cyborg.daemon.survey.report import FILENAME, render_report, write_report
from cyborg.daemon.vision.cooccurrence import Segmentation
from cyborg.daemon.vision.render import segmentation_image
from cyborg.protocol.palette import CLASS_RGB, UNSEGMENTED_RGB, css


def test_the_report_lists_every_station_and_escapes_what_it_quotes(tmp_path: Path) -> None:
    archive = Archive(tmp_path / "archive", "rig<1>")
    archive.open()
    session = archive.new_session()
    site = {"name": "Rio <Tinto>", "latitude": 40.0, "longitude": -3.0, "heading": 90.0}
    first = archive.new_station(session, 1, 300.0, site=site)
    first.finish("complete")
    second = archive.new_station(session, 2, 60.0, site=site)
    second.finish("failed", "camera: <frame unreadable>")
    page = write_report(tmp_path / "archive" / session)
    assert page == tmp_path / "archive" / session / FILENAME
    html = page.read_text()
    assert "st01-300m" in html and "st02-60m" in html
    assert "Rio &lt;Tinto&gt;" in html and "<Tinto>" not in html
    assert "&lt;frame unreadable&gt;" in html and "<frame unreadable>" not in html
    assert render_report(tmp_path / "archive" / session) == html


def test_an_empty_session_still_renders(tmp_path: Path) -> None:
    (tmp_path / "s").mkdir()
    assert "0 station(s)" in render_report(tmp_path / "s")


def _walked(tmp_path: Path) -> Path:
    """A session of three stations as the rig records them: the configured site, a station
    dead-reckoned along the leg walked, one with a GPS fix; points with estimated places, one
    no better than its view's background; the analysis maps; the timings."""
    archive = Archive(tmp_path / "archive", "rig")
    archive.open()
    session = archive.new_session()
    sites = [
        {"latitude": 40.331, "longitude": -3.517, "altitude": 612.5, "source": "config"},
        {
            "latitude": 40.33294,
            "longitude": -3.51587,
            "altitude": None,
            "source": "dead-reckoned",
            "leg": {"from": "st01-300m", "bearing_deg": 24.6, "distance_m": 240.0},
        },
        {"latitude": 40.33331, "longitude": -3.51564, "altitude": 611.0, "source": "gpsd 3D fix"},
    ]
    labels = np.zeros((40, 60), np.uint8)
    labels[10:20, 10:30] = 1
    labels[25:35, 35:55] = 2
    classes = segmentation_image(Segmentation(labels, (), np.zeros((256, 256), np.float32)))
    for index, (distance, site) in enumerate(zip((300.0, 60.0, 10.0), sites, strict=True), 1):
        station = archive.new_station(session, index, distance, site=site | {"name": "Rio"})
        for c in "hsi":
            station.write_png(f"analysis/segmentation_{c}.png", classes)
            station.write_png(f"analysis/uncommon_{c}.png", labels * 32)
        station.write_png("analysis/interest.png", labels * 100)
        place = {"latitude": 40.3341, "longitude": -3.5151, "altitude": 640.0, "range_m": distance}
        points = [
            {"rank": 1, "pan": 20.1, "tilt": 8.4, "score": 4.35, "why": "green patch on buff rock",
             "radius_deg": 1.2, "target": True, "position": place | {"estimated": True}},
            {"rank": 2, "pan": 17.9, "tilt": 9.4, "score": 0.04, "why": "orange patch on buff rock",
             "radius_deg": 0.3, "target": False},
        ]  # fmt: skip
        timing = {"predicted_motion_s": 2.125, "grab_s": 0.31, "analysis_s": 0.47, "wall_s": 3.4}
        station.update(points=points, timing=timing, choice={"rank": 1, "by": "me", "t": 1.8e9})
        station.finish("complete")
    return tmp_path / "archive" / session


def test_timings_read_in_words(tmp_path: Path) -> None:
    html = render_report(_walked(tmp_path))
    assert "predicted motion 2.1 s, grabbing 0.3 s, analysis 0.5 s, station in all 3.4 s" in html
    assert "_s " not in html and "predicted_motion" not in html


def test_each_station_says_where_it_stood_and_how_that_is_known(tmp_path: Path) -> None:
    html = render_report(_walked(tmp_path))
    assert "40.33100, -3.51700, 612 m (the configured site)" in html
    assert "40.33294, -3.51587 (dead-reckoned: 240 m on bearing 25° from st01-300m)" in html
    assert "40.33331, -3.51564, 611 m (fix from gpsd 3D fix)" in html
    assert html.count("target ≈ 40.33410, -3.51510, 640 m") == 3
    assert "estimated, 60 m away" in html


def test_a_point_no_better_than_its_background_is_no_further_target(tmp_path: Path) -> None:
    html = render_report(_walked(tmp_path))
    assert html.count("no further target") >= 3  # one row a station, and the key
    assert "orange patch on buff rock" not in html  # its description is not presented
    assert "class='rank r2'" not in html  # no rank colour: it is no ranked target
    assert "green patch on buff rock" in html


def test_every_class_map_has_its_legend_and_every_map_its_scale(tmp_path: Path) -> None:
    html = render_report(_walked(tmp_path))
    assert html.count("segmentation classes, by area") == 3
    for rgb in (*CLASS_RGB, UNSEGMENTED_RGB):
        assert f"background:{css(rgb)}" in html
    assert html.count("8 rarest") == 9 and html.count("highest in this view") == 3
