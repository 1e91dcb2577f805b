"""How the session report prints on A4: pages, and how full each one is.

Headless Chromium prints the page (WebDriver's print, A4, as ``bench.browser``);
pypdfium2 renders each PDF page and the span from its first inked row to its last is
its fill. A report should print on one page for the session and one for each station,
none under a quarter full. Without a report, a fresh ``cyborg demo`` walk (three
stations) is printed.

Usage: ``python -m bench.printed [REPORT.html ...]``.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from bench.browser import MISSING, chromium

if TYPE_CHECKING:
    import pypdfium2

__all__ = ["demo_report", "page_fill", "printed"]


def demo_report(out: Path) -> Path:
    """A real three-station walk (``cyborg demo``) into ``out``; its report."""
    subprocess.run(
        [sys.executable, "-m", "cyborg.clients", "demo", "--out", str(out)],
        check=True,
        capture_output=True,
        timeout=240,
    )
    (report,) = out.glob("archive/*/report.html")
    return report


def page_fill(page: pypdfium2.PdfPage) -> float:
    """The share of the page's height its content spans, first inked row to last."""
    grey = page.render(scale=0.5, grayscale=True).to_numpy()
    rows = np.flatnonzero((grey.reshape(grey.shape[0], -1) < 245).any(axis=1))
    return (rows[-1] - rows[0] + 1) / grey.shape[0] if rows.size else 0.0


def printed(report: Path) -> pypdfium2.PdfDocument:
    """``report`` printed on A4 by headless Chromium."""
    import pypdfium2  # noqa: PLC0415 - a test extra: collecting this module needs none

    with chromium() as browser:
        browser.open(report.resolve().as_uri())
        return pypdfium2.PdfDocument(browser.print_pdf())


def main(argv: list[str]) -> int:
    if MISSING:
        print(MISSING)
        return 1
    with tempfile.TemporaryDirectory(prefix="cyborg-printed-") as tmp:
        reports = [Path(a) for a in argv] or [demo_report(Path(tmp))]
        for report in reports:
            stations = len(list(report.parent.glob("st*/manifest.json")))
            pdf = printed(report)
            fills = [page_fill(page) for page in pdf]
            pdf.close()
            print(
                f"{report}: {stations} station(s), {len(fills)} A4 page(s) "
                f"(goal {stations + 1}); fill "
                + " ".join(f"{f:.0%}" for f in fills)
                + f"; pages under a quarter full: {sum(f < 0.25 for f in fills)}"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
