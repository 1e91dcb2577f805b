"""The colours of the interest points and of the segmentation classes, wherever they are
drawn: the overlay, class maps and report (``daemon.vision.render``, ``daemon.survey.report``),
the session log's annotations (:mod:`.recording`).

RGB tables; each consumer converts them to its own form (OpenCV's BGR, Foxglove's 0..1, CSS).
Both come from palettes made for colour-blind readers, and the two never share a colour, so a
ring is never mistaken for a class.
"""

from __future__ import annotations

__all__ = ["CLASS_RGB", "POINT_RGB", "UNSEGMENTED_RGB", "bgr", "css", "unit_rgb"]

POINT_RGB = ((230, 159, 0), (86, 180, 233), (213, 94, 0))
"""Ranks 1..3, from the Okabe-Ito palette, which colour-blind readers tell apart: orange,
sky blue, vermillion (each ring also carries its number)."""

CLASS_RGB = (
    (51, 34, 136),  # indigo: class 1, the largest
    (136, 204, 238),  # cyan
    (17, 119, 51),  # green
    (221, 204, 119),  # sand
    (204, 102, 119),  # rose
    (68, 170, 153),  # teal
    (136, 34, 85),  # wine
    (170, 68, 153),  # purple: class 8, the smallest
)
"""Segmentation classes 1..8 (1 = largest area), Paul Tol's "muted" qualitative palette,
which readers with any common colour-vision deficiency tell apart (no red/green pair)."""

UNSEGMENTED_RGB = (0, 0, 0)
"""Pixels no class holds: black."""


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


def css(rgb: tuple[int, int, int]) -> str:
    """The colour as a CSS hex string.

    >>> css(CLASS_RGB[0])
    '#332288'
    """
    return "#{:02x}{:02x}{:02x}".format(*rgb)
