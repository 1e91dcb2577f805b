"""The session report: one self-contained HTML page a geologist reads, on a laptop or on A4.

``<archive>/<session>/report.html`` is rewritten at the end of every station and at every
choice. It needs nothing else: images are embedded (reduced JPEG, PNG for the colour
bars), there is no script and no external style; links lead to every raw product in the
session folder beside it. Per session, a diagram of the approach (stations by distance,
the legs walked with their length and bearing); per station the overlay, the interest
points with their plain-language reasons and their chips, the choice made and when,
the segmentations, the uncommon and interest maps in a perceptual colour map (viridis)
with colour bars, and the timings.
"""

from __future__ import annotations

import asyncio
import base64
import html
import json
import logging
import math
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ..archive import MANIFEST, Station
from ..vision.imageio import encode_image, write_atomic

__all__ = ["FILENAME", "render_report", "update_report", "write_report"]

_LOGGER = logging.getLogger(__name__)

FILENAME = "report.html"
THUMB = 900
"""Longest side of an embedded image, pixels: sharp on a laptop, small in the file."""

_CSS = """
body{font:15px/1.45 system-ui,sans-serif;margin:0 auto;max-width:1100px;padding:1em 1.5em;
color:#222}
h1{font-size:1.5em;margin:.2em 0}h2{font-size:1.2em;border-top:2px solid #bbb;padding-top:.6em}
.meta{color:#555}table{border-collapse:collapse;width:100%}td,th{padding:.3em .5em;
vertical-align:top;border-bottom:1px solid #ddd;text-align:left}img{max-width:100%;height:auto}
.maps{display:grid;grid-template-columns:repeat(3,1fr);gap:.6em}.maps figure{margin:0}
figcaption{font-size:.85em;color:#444}.chip{width:180px}.rank{font-weight:bold;font-size:1.2em}
.r1{color:#b87c00}.r2{color:#2d7fb8}.r3{color:#c04a00}.bar{height:14px;width:100%}
.raw{font-size:.85em;columns:3}.station{break-inside:avoid-page}
@media print{body{max-width:none;font-size:11pt}.station{break-before:page}
a{color:inherit;text-decoration:none}.raw{display:none}@page{size:A4;margin:14mm}}
"""


def write_report(session_dir: Path) -> Path:
    """Render ``session_dir``'s report next to its stations; returns the file written."""
    page = render_report(session_dir)
    path = session_dir / FILENAME
    write_atomic(path, page.encode())
    return path


async def update_report(station: Station) -> None:
    """Rewrite the report of ``station``'s session, off the event loop; a report that cannot
    be written (a full disk) is logged and costs the station nothing."""
    try:
        await asyncio.to_thread(write_report, station.folder.parent)
    except (OSError, ValueError, cv2.error) as exc:
        _LOGGER.warning("session report for %s not written: %s", station.name, exc)


def render_report(session_dir: Path, links: str = "") -> str:
    """The report of one session folder; ``links`` prefixes the raw products' paths (the
    session folder relative to where the page is put)."""
    stations = []
    for manifest in sorted(session_dir.glob(f"*/{MANIFEST}")):
        try:
            stations.append((manifest.parent, json.loads(manifest.read_text())))
        except (OSError, ValueError):
            continue  # a manifest being rewritten: the next report has it
    first = stations[0][1] if stations else {}
    site = first.get("site") or {}
    title = f"Session {session_dir.name}" + (f" — {site['name']}" if site.get("name") else "")
    parts = [
        "<!doctype html><html lang=en><meta charset=utf-8>",
        '<meta name=viewport content="width=device-width,initial-scale=1">',
        f"<title>{_e(title)}</title><style>{_CSS}</style>",
        f"<h1>{_e(title)}</h1>",
        f"<p class=meta>rig {_e(first.get('rig', '?'))} · {len(stations)} station(s) · "
        f"{_e(first.get('started', ''))} · {_e(_where(site))}</p>",
        _approach([m for _, m in stations]),
    ]
    for folder, m in stations:
        parts.append(_station(folder, m, links + folder.name + "/"))
    parts.append("</html>")
    return "\n".join(parts)


def _station(folder: Path, m: dict[str, Any], href: str) -> str:
    analysis = folder / "analysis"
    choice = m.get("choice") or {}
    chosen = (f"chose #{choice['rank']}" if choice.get("rank") else "no target chosen") + (
        f" by {_e(choice.get('by', ''))} at {_time(choice.get('t'))}" if choice else ""
    )
    out = [
        "<section class=station>",
        f"<h2>{_e(m.get('station', folder.name))} · {m.get('distance_m', '?')} m · "
        f"{_e(m.get('status', '?'))}</h2>",
        f"<p class=meta>{_e(m.get('started', ''))} → {_e(m.get('finished') or '…')} · "
        f"{chosen if m.get('points') else _e(m.get('reason', ''))}</p>",
    ]
    if (analysis / "overlay.png").is_file():
        out.append(_img(analysis / "overlay.png", "overlay: the interest points on the mosaic"))
    chips = {c.get("rank"): c for c in m.get("chips", [])}
    if m.get("points"):
        out.append("<table><tr><th>#<th>what<th>where<th>chip</tr>")
        for p in m["points"]:
            chip = chips.get(p["rank"], {})
            chip_path = folder / chip["file"] if chip.get("file") else None
            where = f"pan {p['pan']:.2f}°, tilt {p['tilt']:.2f}°"
            if p.get("azimuth") is not None:
                where = f"azimuth {p['azimuth']:.1f}°, elevation {p['elevation']:.1f}°<br>{where}"
            if p.get("radius_deg"):
                where += f"<br>{2 * p['radius_deg']:.2f}° across"
            out.append(
                f"<tr><td class='rank r{p['rank']}'>{p['rank']}<td>{_e(p.get('why', ''))}"
                f"<br><small>score {p.get('score', 0):.2f}</small><td>{where}<td>"
                + (_img(chip_path, "", "chip") if chip_path and chip_path.is_file() else "")
            )
        out.append("</table>")
    scale = ("0 unsegmented", "8+ rarest")
    maps: list[tuple[str, str, tuple[str, str] | None]] = [
        (f"segmentation_{c}.png", f"segmentation {c.upper()}", None) for c in "hsi"
    ]
    maps += [(f"uncommon_{c}.png", f"uncommon {c.upper()}", scale) for c in "hsi"]
    maps.append(("interest.png", "interest", ("typical", "most uncommon")))
    figures = []
    for name, caption, bar in maps:
        path = analysis / name
        if path.is_file():
            figures.append(_figure(path, caption, bar))
    if figures:
        out.append("<div class=maps>" + "".join(figures) + "</div>")
    timing = m.get("timing") or {}
    if timing:
        out.append(
            "<p class=meta>timings: "
            + ", ".join(f"{_e(k)} {v:.1f} s" for k, v in timing.items() if _num(v))
            + "</p>"
        )
    files = sorted((m.get("files") or {}).keys())
    out.append(
        "<details><summary>raw products</summary><ul class=raw>"
        + "".join(f"<li><a href='{_e(href + f)}'>{_e(f)}</a>" for f in files)
        + "</ul></details></section>"
    )
    return "\n".join(out)


def _approach(manifests: list[dict[str, Any]]) -> str:
    """An SVG of the walk: the cliff at the top, each station at its distance (log scale),
    each leg with its length and bearing (the chosen target's azimuth, else its pan)."""
    if not manifests:
        return "<p>No station yet.</p>"
    width, height, top = 700, 150, 30
    far = max(float(m.get("distance_m", 1)) for m in manifests)
    near = min(float(m.get("distance_m", 1)) for m in manifests)
    span = math.log(far / near) if far > near else 1.0

    def x(d: float) -> float:
        return 60 + (width - 120) * (math.log(far / d) / span if far > near else 0.5)

    svg = [
        f"<svg viewBox='0 0 {width} {height}' width='100%' role='img' "
        "aria-label='the approach: stations by distance from the outcrop'>",
        # every attribute quoted: unquoted, a trailing / would end up in the value
        f"<line x1='{width - 30}' y1='10' x2='{width - 30}' y2='{height - 10}' "
        "stroke='#8a6d3b' stroke-width='6'/>"
        f"<text x='{width - 38}' y='20' font-size='12' text-anchor='end'>outcrop</text>",
    ]
    prev: dict[str, Any] | None = None
    for m in manifests:
        d = float(m.get("distance_m", 1))
        cx = x(d)
        if prev is not None:
            px = x(float(prev["distance_m"]))
            leg = float(prev["distance_m"]) - d
            svg.append(
                f"<line x1='{px:.0f}' y1='{top + 40}' x2='{cx:.0f}' y2='{top + 40}' "
                "stroke='#555' stroke-dasharray='4 3'/>"
                f"<text x='{(px + cx) / 2:.0f}' y='{top + 30}' font-size='12' text-anchor='middle'>"
                f"{leg:g} m {_e(_bearing(prev))}</text>"
            )
        svg.append(
            f"<circle cx='{cx:.0f}' cy='{top + 40}' r='7' fill='#2d7fb8'/>"
            f"<text x='{cx:.0f}' y='{top + 70}' font-size='12' text-anchor='middle'>"
            f"{_e(m.get('station', ''))}</text>"
            f"<text x='{cx:.0f}' y='{top + 86}' font-size='11' text-anchor='middle' fill='#555'>"
            f"{d:g} m</text>"
        )
        prev = m
    svg.append("</svg>")
    return "".join(svg)


def _bearing(m: dict[str, Any]) -> str:
    rank = (m.get("choice") or {}).get("rank")
    point = next((p for p in m.get("points", []) if p.get("rank") == rank), None)
    if point is None:
        return ""
    if point.get("azimuth") is not None:
        return f"towards azimuth {point['azimuth']:.0f}° (#{rank})"
    return f"towards pan {point['pan']:.0f}° (#{rank})"


def _figure(path: Path, caption: str, bar: tuple[str, str] | None) -> str:
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is None:
        return ""
    if bar is not None:  # grey maps in viridis, with their scale
        grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        image = cv2.applyColorMap(grey, cv2.COLORMAP_VIRIDIS)
        ramp = cv2.applyColorMap(
            np.tile(np.arange(256, dtype=np.uint8), (14, 1)), cv2.COLORMAP_VIRIDIS
        )
        legend = (
            f"<img class=bar alt='colour bar' src='{_data(ramp, '.png')}'>"
            f"<figcaption style='display:flex;justify-content:space-between'>"
            f"<span>{_e(bar[0])}</span><span>{_e(bar[1])}</span></figcaption>"
        )
    else:
        legend = ""
    return (
        f"<figure><img alt='{_e(caption)}' src='{_data(image, '.jpg')}'>{legend}"
        f"<figcaption>{_e(caption)}</figcaption></figure>"
    )


def _img(path: Path, caption: str, cls: str = "") -> str:
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        return ""
    klass = f" class={cls}" if cls else ""
    tag = f"<img{klass} alt='{_e(caption or path.name)}' src='{_data(image, '.jpg')}'>"
    return f"<figure>{tag}<figcaption>{_e(caption)}</figcaption></figure>" if caption else tag


def _data(image: np.ndarray, ext: str) -> str:
    rows, cols = image.shape[:2]
    scale = THUMB / max(rows, cols)
    if scale < 1:
        image = cv2.resize(
            image, (round(cols * scale), round(rows * scale)), interpolation=cv2.INTER_AREA
        )
    data = encode_image(image, ext, quality=85)
    mime = "image/jpeg" if ext == ".jpg" else "image/png"
    return f"data:{mime};base64,{base64.b64encode(data).decode()}" if data else ""


def _where(site: dict[str, Any]) -> str:
    lat, lon = site.get("latitude"), site.get("longitude")
    if lat is None or lon is None:
        return "position unknown"
    alt = f", {site['altitude']:.0f} m" if site.get("altitude") is not None else ""
    return f"{lat:.5f}, {lon:.5f}{alt} ({site.get('source', '')})"


def _time(t: Any) -> str:
    return time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(t)) + " UTC" if _num(t) else ""


def _num(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _e(text: Any) -> str:
    return html.escape(str(text), quote=True)
