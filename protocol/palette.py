"""The colours of the interest points, wherever they are drawn: the overlay and report
(``daemon.vision.render``), the session log's annotations (:mod:`.recording`).

One RGB table; each consumer converts it to its own form (OpenCV's BGR, Foxglove's 0..1).
"""

from __future__ import annotations

__all__ = ["POINT_RGB", "bgr", "unit_rgb"]

POINT_RGB = ((230, 159, 0), (86, 180, 233), (213, 94, 0))
"""Ranks 1..3, from the Okabe-Ito palette, which colour-blind readers tell apart: orange,
sky blue, vermillion (each ring also carries its number)."""


def bgr(rgb: tuple[int, int, int]) -> tuple[int, int, int]:
    """The colour as OpenCV draws it.

    >>> bgr(POINT_RGB[0])
    (0, 159, 230)
    """
    r, g, b = rgb
    return b, g, r


def unit_rgb(rgb: tuple[int, int, int]) -> tuple[float, float, float]:
    """The colour as 0..1 fractions, to three decimals (Foxglove's ``Color``).

    >>> unit_rgb(POINT_RGB[1])
    (0.337, 0.706, 0.914)
    """
    r, g, b = rgb
    return round(r / 255, 3), round(g / 255, 3), round(b / 255, 3)
