"""The session report, rendered in-process from an archive's stations."""

from __future__ import annotations

from pathlib import Path

from cyborg.daemon.archive import Archive
from cyborg.daemon.survey.report import FILENAME, render_report, write_report


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
