"""Pictures of the science products, drawn the way the seed papers drew them.

Class maps use ``protocol.palette``'s colour-blind-safe class colours; every stand-alone
map (:func:`class_figure`, :func:`map_figure`, :func:`cooccurrence_plot`) carries its own
scale: axes in the map's pixels (or values) and a legend or a colour bar with values.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from cyborg.protocol.palette import CLASS_RGB, POINT_RGB, UNSEGMENTED_RGB, bgr

from .cooccurrence import Segmentation
from .interest import InterestPoint

__all__ = [
    "CLASS_COLOURS",
    "POINT_COLOURS",
    "class_figure",
    "cooccurrence_plot",
    "grey_ramp",
    "map_figure",
    "overlay",
    "segmentation_image",
]

CLASS_COLOURS = tuple(bgr(rgb) for rgb in CLASS_RGB)
"""BGR colour of class k at index k - 1, in the paper's order by class area
(``protocol.palette``: Paul Tol's muted, safe for colour-blind readers)."""

POINT_COLOURS = tuple(bgr(rgb) for rgb in POINT_RGB)
"""BGR colour of interest point k at index k - 1 (``protocol.palette``: orange, sky blue,
vermillion)."""

_LUT = np.zeros((256, 1, 3), np.uint8)
_LUT[0, 0] = bgr(UNSEGMENTED_RGB)
for _k, _c in enumerate(CLASS_COLOURS, start=1):
    _LUT[_k, 0] = _c

_FONT = cv2.FONT_HERSHEY_SIMPLEX
_INK = (40, 40, 40)
_MIN_WIDTH = 480
"""A figure's map is enlarged (by whole pixels) to at least this width, so its labels stay
readable beside it."""


def segmentation_image(seg: Segmentation) -> np.ndarray:
    """Colour-code a segmentation: (M, N, 3) uint8 BGR, black = unsegmented.

    Examples
    --------
    >>> seg = Segmentation(np.array([[0, 1, 2]], np.uint8), (), np.zeros((256, 256), np.float32))
    >>> segmentation_image(seg)[0].tolist()
    [[0, 0, 0], [136, 34, 51], [238, 204, 136]]
    """
    return cv2.LUT(cv2.merge([seg.labels] * 3), _LUT)


def grey_ramp(values: np.ndarray, vmax: float | None = None) -> np.ndarray:
    """Map values 0..vmax linearly to grey 0..255: (M, N) uint8.

    Examples
    --------
    >>> grey_ramp(np.array([[0.0, 4.0, 8.0]]), vmax=8).tolist()
    [[0, 128, 255]]
    """
    top = float(values.max()) if vmax is None else float(vmax)
    if top <= 0:
        return np.zeros(values.shape, np.uint8)
    return cv2.convertScaleAbs(values.astype(np.float32), alpha=255.0 / top)


def class_figure(seg: Segmentation, title: str) -> np.ndarray:
    """The class map (:func:`segmentation_image`) as a figure: pixel axes and a legend that
    names each class's colour (1 = largest area) and the unsegmented black.

    Returns (P, Q, 3) uint8 BGR, larger than the map.

    Examples
    --------
    >>> seg = Segmentation(np.zeros((30, 40), np.uint8), (), np.zeros((256, 256), np.float32))
    >>> fig = class_figure(seg, "segmentation H")
    >>> fig.shape[0] > 30 and fig.shape[1] > 480, fig.dtype
    (True, dtype('uint8'))
    """
    image = _shown(segmentation_image(seg))
    legend = _class_legend(len(seg.classes))
    rows, cols = seg.labels.shape
    return _compose(image, (cols, rows), legend, title, _PIXELS)


def map_figure(values: np.ndarray, title: str, vmax: float | None = None) -> np.ndarray:
    """A map of values 0..``vmax`` (its maximum if None) in viridis, with pixel axes and a
    colour bar ticked in the map's own values.

    Parameters
    ----------
    values : (M, N) array
        The map (an uncommon map, the interest map).
    title : str
        Written above the map; say what the values are.
    vmax : float, optional
        The value drawn brightest; higher values saturate.

    Returns
    -------
    (P, Q, 3) uint8 BGR

    Examples
    --------
    >>> fig = map_figure(np.linspace(0, 8, 1200).reshape(30, 40), "uncommon H", vmax=8)
    >>> fig.shape[0] > 30 and fig.shape[1] > 480
    True
    """
    if values.ndim != 2:
        raise ValueError(f"a map is (M, N), not {values.shape}")
    top = float(values.max()) if vmax is None else float(vmax)
    image = _shown(cv2.applyColorMap(grey_ramp(values, top), cv2.COLORMAP_VIRIDIS))
    ticks = [(v / top, f"{v:g}") for v in _nice_ticks(top)] if top > 0 else [(0.0, "0")]
    legend = _colour_bar(max(image.shape[0], 160), ticks, "value", cv2.COLORMAP_VIRIDIS)
    rows, cols = values.shape
    return _compose(image, (cols, rows), legend, title, _PIXELS)


def cooccurrence_plot(seg: Segmentation, size: int = 512) -> np.ndarray:
    """The pair histogram on a log scale with each class's region in its colour: the block
    of values it owns (a square on the diagonal) or its disc; axes in values 0..255, a
    colour bar in pair counts and the class legend beside it.

    Row = first value (top = 0), column = neighbour value; (P, Q, 3) uint8 BGR, the plot
    itself ``size`` square.
    """
    hist = np.log1p(seg.histogram.astype(np.float32))
    img = grey_ramp(hist)
    img = cv2.resize(img, (size, size), interpolation=cv2.INTER_NEAREST)
    img = cv2.applyColorMap(img, cv2.COLORMAP_BONE)
    scale = size / 256.0
    for k, cls in enumerate(seg.classes, start=1):
        colour = CLASS_COLOURS[k - 1]
        if cls.is_block:
            lo, hi = round(cls.lo * scale), round((cls.hi + 1) * scale) - 1
            cv2.rectangle(img, (lo, lo), (hi, hi), colour, 2, cv2.LINE_AA)
            continue
        centre = (round((cls.center + 0.5) * scale),) * 2
        cv2.circle(img, centre, max(2, round(cls.radius * scale)), colour, 2, cv2.LINE_AA)
    cv2.line(img, (0, 0), (size - 1, size - 1), (80, 80, 80), 1)
    top = float(hist.max())
    counts = [0] + [10**e for e in range(1, math.floor(top / math.log(10)) + 1)]
    ticks = [(math.log1p(c) / top, f"{c:g}") for c in counts] if top > 0 else [(0.0, "0")]
    bar = _colour_bar(size // 2, ticks, "pairs", cv2.COLORMAP_BONE)
    legend = _stack(bar, _class_legend(len(seg.classes), unsegmented=False))
    unit = "value (rows) against its neighbour's value (columns), 0..255"
    return _compose(img, (256, 256), legend, "co-occurrence of neighbouring values", unit)


def overlay(
    bgr: np.ndarray, points: list[InterestPoint], scale: float = 1.0, notes: Sequence[str] = ()
) -> np.ndarray:
    """Draw the interest points on a copy of the image, best first (``POINT_COLOURS``);
    a point that is no further target (``target`` False) gets no ring.

    Each ring lies outside the point's radius, so it frames the target instead of hiding
    it, and its number stands beside it. ``scale`` converts point coordinates to ``bgr``
    pixels (input vs analysed image). ``notes`` (the analysis's, e.g. "one class in H, S and
    I: nothing is uncommon at this resolution") are written across the top, so an overlay
    without a point says why.

    >>> img = np.full((120, 200, 3), 128, np.uint8)
    >>> bool((overlay(img, [], notes=["one class in H, S and I"]) != img).any())
    True
    """
    out = bgr.copy()
    rows, cols = out.shape[:2]
    thick = max(1, round(min(rows, cols) / 300))
    font = 0.45 * thick
    _caption(out, notes, thick)
    for p in points:
        if not p.target:
            continue
        colour = POINT_COLOURS[p.rank - 1] if p.rank <= len(POINT_COLOURS) else (0, 255, 255)
        centre = (round(p.x * scale), round(p.y * scale))
        r = max(4, round(1.25 * p.radius * scale) + 2 * thick)
        cv2.circle(out, centre, r, (0, 0, 0), thick + 2, cv2.LINE_AA)
        cv2.circle(out, centre, r, colour, thick, cv2.LINE_AA)
        label = str(p.rank)
        (tw, th), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, font, thick)
        x = (
            centre[0] + r + 2 * thick
            if centre[0] + r + tw + 4 * thick < cols
            else centre[0] - r - tw - 2 * thick
        )
        y = min(max(centre[1] + th // 2, th + 1), rows - 2)
        cv2.putText(
            out, label, (x, y), cv2.FONT_HERSHEY_SIMPLEX, font, (0, 0, 0), thick + 2, cv2.LINE_AA
        )
        cv2.putText(out, label, (x, y), cv2.FONT_HERSHEY_SIMPLEX, font, colour, thick, cv2.LINE_AA)
    return out


def _caption(out: np.ndarray, notes: Sequence[str], thick: int) -> None:
    """Write ``notes`` in white on black outline down from the top-left corner, each cut
    after its colon when too wide and shrunk to the image's width (in place)."""
    cols = out.shape[1]
    lines = []
    for note in notes:
        head, sep, tail = note.partition(": ")
        wide = cv2.getTextSize(note, cv2.FONT_HERSHEY_SIMPLEX, 0.45 * thick, thick)[0][0]
        lines += [head + sep.rstrip(), tail] if sep and wide > cols - 8 else [note]
    y = 4
    for line in lines:
        size = 0.45 * thick
        (tw, th), _ = cv2.getTextSize(line, cv2.FONT_HERSHEY_SIMPLEX, size, thick)
        size *= min(1.0, (cols - 8) / max(tw, 1))
        th = max(1, round(th * size / (0.45 * thick)))
        y += th + 4 * thick
        for colour, width in (((0, 0, 0), thick + 2), ((255, 255, 255), thick)):
            cv2.putText(
                out, line, (4, y), cv2.FONT_HERSHEY_SIMPLEX, size, colour, width, cv2.LINE_AA
            )


_PIXELS = "pixels of the analysed image (column across, row down)"


def _nice_ticks(top: float, count: int = 5) -> list[float]:
    """Round values from 0 to ``top``, about ``count`` steps.

    >>> _nice_ticks(360), _nice_ticks(8), _nice_ticks(0.5)
    ([0, 100, 200, 300], [0, 2, 4, 6, 8], [0, 0.1, 0.2, 0.3, 0.4, 0.5])
    """
    if top <= 0:
        return [0]
    raw = top / count
    mag = 10.0 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 5, 10) if m * mag >= raw)
    values = (round(i * step, 10) for i in range(int(top / step + 1e-9) + 1))
    return [int(v) if v == int(v) else v for v in values]


def _shown(image: np.ndarray) -> np.ndarray:
    """A small map enlarged by whole pixels to ``_MIN_WIDTH`` (never past 2000 px a side)."""
    rows, cols = image.shape[:2]
    zoom = max(1, min(math.ceil(_MIN_WIDTH / cols), 2000 // max(rows, cols)))
    if zoom == 1:
        return image
    return cv2.resize(image, (cols * zoom, rows * zoom), interpolation=cv2.INTER_NEAREST)


def _text(img: np.ndarray, text: str, org: tuple[float, float], size: float = 0.4) -> None:
    cv2.putText(img, text, (round(org[0]), round(org[1])), _FONT, size, _INK, 1, cv2.LINE_AA)


def _width(text: str, size: float = 0.4) -> int:
    return cv2.getTextSize(text, _FONT, size, 1)[0][0]


def _colour_bar(
    height: int, ticks: list[tuple[float, str]], label: str, colormap: int
) -> np.ndarray:
    """A vertical colour bar (top = 1, bottom = 0) under its ``label``, each tick
    (fraction, text) written beside it."""
    top, bar_w = 22, 18
    width = bar_w + 12 + max(_width(t) for _, t in ticks)
    width = max(width, _width(label) + 2)
    panel = np.full((top + height + 8, width, 3), 255, np.uint8)
    ramp = np.linspace(255, 0, height).astype(np.uint8)[:, None].repeat(bar_w, 1)
    panel[top : top + height, :bar_w] = cv2.applyColorMap(ramp, colormap)
    cv2.rectangle(panel, (0, top), (bar_w - 1, top + height - 1), _INK, 1)
    _text(panel, label, (0, top - 8))
    for frac, text in ticks:
        y = top + round((1 - min(max(frac, 0.0), 1.0)) * (height - 1))
        cv2.line(panel, (bar_w, y), (bar_w + 4, y), _INK, 1)
        _text(panel, text, (bar_w + 7, y + 4))
    return panel


def _class_legend(count: int, unsegmented: bool = True) -> np.ndarray:
    """A swatch and a name for each of ``count`` classes (and the unsegmented black)."""
    entries = [
        (CLASS_COLOURS[k - 1], f"class {k}" + (" (largest)" if k == 1 else ""))
        for k in range(1, count + 1)
    ]
    if count > 1:
        entries[-1] = (entries[-1][0], f"class {count} (smallest)")
    if unsegmented:
        entries.append((bgr(UNSEGMENTED_RGB), "unsegmented"))
    line, top = 20, 22
    width = 24 + max([_width("classes")] + [_width(t) for _, t in entries])
    panel = np.full((top + line * len(entries) + 4, width, 3), 255, np.uint8)
    _text(panel, "classes", (0, top - 8))
    for i, (colour, text) in enumerate(entries):
        y = top + i * line
        cv2.rectangle(panel, (0, y + 2), (15, y + 16), colour, -1)
        cv2.rectangle(panel, (0, y + 2), (15, y + 16), _INK, 1)
        _text(panel, text, (22, y + 14))
    return panel


def _stack(*panels: np.ndarray) -> np.ndarray:
    """Legend panels one above the other, left-aligned on white."""
    width = max(p.shape[1] for p in panels)
    padded = [
        np.pad(p, ((0, 8), (0, width - p.shape[1]), (0, 0)), constant_values=255) for p in panels
    ]
    return np.vstack(padded)


def _compose(
    image: np.ndarray, extent: tuple[float, float], legend: np.ndarray, title: str, unit: str
) -> np.ndarray:
    """``image`` on white under ``title``, its axes ticked from 0 to ``extent`` = (across,
    down) in ``unit``, ``legend`` to its right."""
    left, top, bottom, gap = 52, 30, 44, 18
    h, w = image.shape[:2]
    lh, lw = legend.shape[:2]
    width = max(left + w + gap + lw + 16, left + _width(unit) + 8, left + _width(title, 0.5) + 8)
    canvas = np.full((top + max(h, lh) + bottom, width, 3), 255, np.uint8)
    canvas[top : top + h, left : left + w] = image
    canvas[top : top + lh, left + w + gap : left + w + gap + lw] = legend
    cv2.rectangle(canvas, (left - 1, top - 1), (left + w, top + h), _INK, 1)
    across, down = extent
    for v in _nice_ticks(across):
        x = left + round(v * w / across)
        cv2.line(canvas, (x, top + h), (x, top + h + 5), _INK, 1)
        _text(canvas, f"{v:g}", (x - _width(f"{v:g}") / 2, top + h + 19))
    for v in _nice_ticks(down):
        y = top + round(v * h / down)
        cv2.line(canvas, (left - 5, y), (left, y), _INK, 1)
        _text(canvas, f"{v:g}", (left - 8 - _width(f"{v:g}"), y + 4))
    _text(canvas, unit, (left, top + h + 38))
    _text(canvas, title, (left, 20), 0.5)
    return canvas
