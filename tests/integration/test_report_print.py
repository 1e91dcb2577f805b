"""The report of a real three-station walk (``cyborg demo``: daemon, emulated unit, simulated
camera, worker) printed on A4 by headless Chromium: one page for the session and one for each
station, each station's figures with its table, no page under a quarter full."""

from __future__ import annotations

from pathlib import Path

import pytest

from bench.browser import MISSING
from bench.printed import demo_report, page_fill, printed

pytestmark = [pytest.mark.timeout(300), pytest.mark.skipif(bool(MISSING), reason=MISSING or "")]
pytest.importorskip(
    "pypdfium2", reason="pypdfium2 not installed: `pip install pypdfium2` to measure printed pages"
)


def test_the_report_prints_a_page_for_the_session_and_one_a_station(tmp_path: Path) -> None:
    report = demo_report(tmp_path)
    stations = sorted(p.parent.name for p in report.parent.glob("st*/manifest.json"))
    assert len(stations) == 3
    pdf = printed(report)
    filled = [page_fill(page) for page in pdf]
    texts = [page.get_textpage().get_text_range() for page in pdf]
    pdf.close()
    assert len(filled) == len(stations) + 1, filled
    assert min(filled) >= 0.25, filled
    for station, text in zip(stations, texts[1:], strict=True):  # its table and maps together
        assert station in text and "segmentation classes, by area" in text
        assert "predicted motion" in text and "predicted_motion_s" not in text
