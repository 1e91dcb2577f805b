"""The session report: one self-contained HTML page a geologist reads, on a laptop or on A4.

``<archive>/<session>/report.html`` is rewritten at the end of every station and at every
choice. It needs nothing else: images are embedded (reduced JPEG, PNG for the colour
bars), there is no script and no external style; links lead to every raw product in the
session folder beside it. Per session, a table of the stations (where each stood and how
that is known, what was chosen) and a diagram of the approach (stations by distance, the
legs walked with their length and bearing); per station its timings in words, the overlay,
the interest points with their plain-language reasons, estimated positions and chips (a
point no better than its view's background says "no further target"), the choice made and
when, the segmentations with their class legend (``protocol.palette``), the uncommon and
interest maps in a perceptual colour map (viridis) with colour bars and values.

Printed on A4 the session fills one page and each station one more: a station's figures
stay with its table (``break-inside: avoid``), the raw-product links are left off paper.
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

from cyborg.protocol.aims import EXCLUSIONS, KINDS, parse_aim
from cyborg.protocol.palette import CLASS_RGB, POINT_RGB, UNSEGMENTED_RGB, css

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
.meta{color:#555;margin:.3em 0}table{border-collapse:collapse;width:100%}td,th{padding:.3em .5em;
vertical-align:top;border-bottom:1px solid #ddd;text-align:left}img{max-width:100%;height:auto}
.maps{display:grid;grid-template-columns:repeat(4,1fr);gap:.6em}figure{margin:0}
figcaption{font-size:.85em;color:#444}.chip{width:180px}.rank{font-weight:bold;font-size:1.2em}
.r1{color:#b87c00}.r2{color:#2d7fb8}.r3{color:#c04a00}.bar{height:14px;width:100%;display:block}
.ticks{display:flex;justify-content:space-between;font-size:.8em;color:#444}
.where{white-space:nowrap}.legend li{white-space:nowrap;break-inside:avoid}
.none td{color:#777}.legend ul{list-style:none;padding:0;margin:.2em 0;font-size:.85em}
.legend i{display:inline-block;width:1.1em;height:1.1em;margin-right:.4em;vertical-align:-.2em;
border:1px solid #555;-webkit-print-color-adjust:exact;print-color-adjust:exact}
.overview td:first-child{white-space:nowrap}.raw{font-size:.85em;columns:3}
.key{padding-left:1.2em}.key li{margin:.2em 0}
@media print{
@page{size:A4;margin:12mm}
body{max-width:none;font-size:9pt;line-height:1.3;padding:0}
h1{font-size:15pt}h2{font-size:12pt;margin:0 0 .3em;padding-top:.3em;break-after:avoid}
.station{break-before:page;break-inside:avoid}.brief{break-before:auto}
.station table,.maps,figure,tr{break-inside:avoid}
.overlay img{max-height:75mm;width:auto;display:block;margin:0 auto}
.chip{width:20mm}td,th{padding:.15em .4em}.maps{gap:2mm}.maps img{max-height:34mm;width:auto}
.legend ul{columns:2;font-size:8pt}
a{color:inherit;text-decoration:none}details{display:none}}
"""

_TIMINGS = {
    "predicted_motion_s": "predicted motion",
    "grab_s": "grabbing",
    "analysis_s": "analysis",
    "wall_s": "station in all",
}
"""The manifest's timing keys in words; another key reads as its name without the unit."""

_RINGS = " ".join(
    f"<svg width=14 height=14 aria-hidden=true><circle cx=7 cy=7 r=5 fill=none "
    f"stroke='{css(rgb)}' stroke-width=2.5 /></svg> #{k}"
    for k, rgb in enumerate(POINT_RGB, start=1)
)
_KEY = f"""<h2>Reading a station's page</h2><ul class=key>
<li>Overlay: the interest points, ringed and numbered by rank ({_RINGS}). A point that cannot
be told from its view's background is listed as "no further target", with no ring and no chip.
<li>Where: the unit's pan and tilt; azimuth and elevation when the heading is known; the
target's size in degrees across; its place, estimated from where the station stood, the
direction and the range, when a range is known.
<li>Aim: what the station was after, as the scientist set it: points of the sought kind are
ranked first, the kinds set aside last; none is hidden ("any": the science's own ranking).
<li>Stood at: a GPS fix when there was one, else the configured site for the first station,
else dead-reckoned along the leg walked from the station before.
<li>Segmentations: each plane (H hue, S saturation, I intensity) in up to 8 classes, coloured by
area (class 1 the largest) in colours that colour-blind readers tell apart; black is
unsegmented.
<li>Uncommon maps: per plane, 0 (unsegmented) to 8 (the rarest class). Interest: their
weighted sum, blurred: 0 is typical, the brightest is the most uncommon in the view.
<li>Every raw product (planes, maps, chips, tiles) is in the station's folder, linked under
each station on screen; each map also stands alone with its axes and scale (figure_*.png).
</ul>"""
"""Told once, on the first page, instead of under every figure."""

_UNCOMMON_TICKS = ("0 unsegmented", "2", "4", "6", "8 rarest")
_INTEREST_TICKS = ("0 typical", "highest in this view")


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
        f"{_e(first.get('started', ''))}</p>",
        _overview([m for _, m in stations]),
        _approach([m for _, m in stations]),
        _KEY if stations else "",
    ]
    for folder, m in stations:
        parts.append(_station(folder, m, links + folder.name + "/"))
    parts.append("</html>")
    return "\n".join(parts)


def _overview(manifests: list[dict[str, Any]]) -> str:
    """One row a station: where it stood (and how that is known), how it ended, the choice."""
    if not manifests:
        return ""
    rows = "".join(
        f"<tr><td>{_e(m.get('station', '?'))}<td>{m.get('distance_m', '?')} m"
        f"<td>{_e(_stood(m.get('site') or {}))}<td>{_e(_aim_of(m) or '?')}"
        f"<td>{_e(m.get('status', '?'))}"
        f"<td>{_e(_chosen(m))}<br><small>{_e((_chosen_point(m) or {}).get('why', ''))}</small>"
        for m in manifests
    )
    return (
        "<table class=overview><tr><th>station<th>distance<th>stood at<th>aim<th>status"
        f"<th>choice</tr>{rows}</table>"
    )


def _aim_of(m: dict[str, Any]) -> str:
    """The aim of study a station's plan records ('' for a station recorded before aims)."""
    return str((m.get("plan") or {}).get("aim") or "")


def _aim_words(text: str) -> str:
    """An aim as a field scientist reads it: what it sought first, what it set aside.

    >>> _aim_words("dark+no-sky")
    'dark (dark features: wet stains, dark lenses, desert varnish); set aside: no-sky'
    """
    try:
        aim = parse_aim(text)
    except ValueError:
        return text
    aside = [name for name in EXCLUSIONS if name in aim.exclude]
    return f"{aim.kind} ({KINDS[aim.kind]})" + (f"; set aside: {', '.join(aside)}" if aside else "")


def _station(folder: Path, m: dict[str, Any], href: str) -> str:
    analysis = folder / "analysis"
    timing = ", ".join(
        f"{_e(_TIMINGS.get(k, k.removesuffix('_s').replace('_', ' ')))} {v:.1f} s"
        for k, v in (m.get("timing") or {}).items()
        if _num(v)
    )
    head = [
        f"<h2>{_e(m.get('station', folder.name))} · {m.get('distance_m', '?')} m · "
        f"{_e(m.get('status', '?'))}</h2>",
        f"<p class=meta>{_e(m.get('started', ''))} → {_e(m.get('finished') or '…')} · "
        f"{_e(_chosen(m) if m.get('points') else m.get('reason', ''))}"
        + (f"<br>aim: {_e(_aim_words(_aim_of(m)))}" if _aim_of(m) else "")
        + (f"<br>timings: {timing}" if timing else "")
        + f"<br>stood at: {_e(_stood(m.get('site') or {}))}</p>",
    ]
    out: list[str] = []
    if (analysis / "overlay.png").is_file():
        out.append(
            "<div class=overlay>"
            + _img(analysis / "overlay.png", "overlay: the interest points on the mosaic")
            + "</div>"
        )
    chips = {c.get("rank"): c for c in m.get("chips", [])}
    if m.get("points"):
        out.append("<table><tr><th>#<th>what<th>where<th>chip</tr>")
        out += [_point(p, folder, chips.get(p.get("rank"), {})) for p in m["points"]]
        out.append("</table>")
    segmentations = "".join(
        _figure(analysis / f"segmentation_{c}.png", f"segmentation {c.upper()}", None)
        for c in "hsi"
    )
    maps = "".join(
        _figure(analysis / f"uncommon_{c}.png", f"uncommon {c.upper()}", _UNCOMMON_TICKS)
        for c in "hsi"
    ) + _figure(analysis / "interest.png", "interest", _INTEREST_TICKS)
    if segmentations or maps:
        legend = _class_legend() if segmentations else ""
        out.append(f"<div class=maps>{segmentations}{legend}{maps}</div>")
    files = sorted((m.get("files") or {}).keys())
    raw = (
        "<details><summary>raw products</summary><ul class=raw>"
        + "".join(f"<li><a href='{_e(href + f)}'>{_e(f)}</a>" for f in files)
        + "</ul></details></section>"
    )
    # a station with nothing but its header (a failed one) takes no page of its own
    section = "<section class=station>" if out else "<section class='station brief'>"
    return "\n".join([section, *head, *out, raw])


def _point(p: dict[str, Any], folder: Path, chip: dict[str, Any]) -> str:
    """One table row: the point's reason, where it lies (and its estimated place), its chip;
    a point no better than the background is only named as such, with no chip."""
    rank = p.get("rank", "?")
    score = f"<small>score {p.get('score', 0):.2f}</small>"
    if p.get("target") is False:
        return (
            f"<tr class=none><td class=rank>{rank}<td colspan=3>no further target: "
            f"not distinguishable from this view's background<br>{score}"
        )
    where = f"pan {p['pan']:.2f}°, tilt {p['tilt']:.2f}°"
    if p.get("azimuth") is not None:
        where = f"azimuth {p['azimuth']:.1f}°, elevation {p['elevation']:.1f}°<br>{where}"
    if p.get("radius_deg"):
        where += f"<br>{2 * p['radius_deg']:.2f}° across"
    place = p.get("position") or {}
    if place.get("latitude") is not None and place.get("longitude") is not None:
        alt = f", {place['altitude']:.0f} m" if _num(place.get("altitude")) else ""
        away = f", {place['range_m']:g} m away" if _num(place.get("range_m")) else ""
        where += (
            f"<br>target ≈ {place['latitude']:.5f}, {place['longitude']:.5f}{alt}"
            f"<br><small>{'estimated' if place.get('estimated', True) else 'measured'}"
            f"{away}</small>"
        )
    chip_path = folder / chip["file"] if chip.get("file") else None
    return (
        f"<tr><td class='rank r{rank}'>{rank}<td>{_e(p.get('why', ''))}<br>{score}"
        f"<td class=where>{where}<td>"
        + (_img(chip_path, "", "chip") if chip_path and chip_path.is_file() else "")
    )


def _chosen(m: dict[str, Any]) -> str:
    choice = m.get("choice") or {}
    said = f"chose #{choice['rank']}" if choice.get("rank") else "no target chosen"
    return said + (f" by {choice.get('by', '')} at {_time(choice.get('t'))}" if choice else "")


def _chosen_point(m: dict[str, Any]) -> dict[str, Any] | None:
    rank = (m.get("choice") or {}).get("rank")
    return next((p for p in m.get("points", []) if p.get("rank") == rank), None)


def _class_legend() -> str:
    """The segmentation colours: class k is the k-th largest of its plane."""
    last = len(CLASS_RGB)
    names = {1: "1 largest", last: f"{last} smallest"}
    items = "".join(
        f"<li><i style='background:{css(rgb)}'></i>{names.get(k, k)}"
        for k, rgb in enumerate(CLASS_RGB, start=1)
    )
    return (
        "<figure class=legend><figcaption>segmentation classes, by area</figcaption>"
        f"<ul>{items}<li><i style='background:{css(UNSEGMENTED_RGB)}'></i>unsegmented</ul>"
        "</figure>"
    )


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
    point = _chosen_point(m)
    if point is None:
        return ""
    if point.get("azimuth") is not None:
        return f"towards azimuth {point['azimuth']:.0f}° (#{point['rank']})"
    return f"towards pan {point['pan']:.0f}° (#{point['rank']})"


def _figure(path: Path, caption: str, ticks: tuple[str, ...] | None) -> str:
    """A map; a grey one (``ticks`` given) in viridis over its colour bar and values."""
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED) if path.is_file() else None
    if image is None:
        return ""
    legend = ""
    if ticks is not None:
        grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        image = cv2.applyColorMap(grey, cv2.COLORMAP_VIRIDIS)
        ramp = cv2.applyColorMap(
            np.tile(np.arange(256, dtype=np.uint8), (14, 1)), cv2.COLORMAP_VIRIDIS
        )
        legend = f"<img class=bar alt='colour bar' src='{_data(ramp, '.png')}'>" + (
            "<div class=ticks>" + "".join(f"<span>{_e(t)}</span>" for t in ticks) + "</div>"
        )
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


def _stood(site: dict[str, Any]) -> str:
    """Where a station stood and how that is known: a GPS fix, the configured site, or
    dead-reckoned along the leg walked from the station before."""
    lat, lon = site.get("latitude"), site.get("longitude")
    if lat is None or lon is None:
        return "position unknown"
    alt = f", {site['altitude']:.0f} m" if _num(site.get("altitude")) else ""
    source = site.get("source") or "unknown"
    if source == "config":
        how = "the configured site"
    elif source == "dead-reckoned":
        leg = site.get("leg") or {}
        how = "dead-reckoned" + (
            f": {leg['distance_m']:g} m on bearing {leg['bearing_deg']:.0f}° "
            f"from {leg.get('from') or 'the station before'}"
            if _num(leg.get("distance_m")) and _num(leg.get("bearing_deg"))
            else ""
        )
    elif source == "unknown":
        how = "source unknown"
    else:
        how = f"fix from {source}"
    return f"{lat:.5f}, {lon:.5f}{alt} ({how})"


def _time(t: Any) -> str:
    return time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(t)) + " UTC" if _num(t) else ""


def _num(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _e(text: Any) -> str:
    return html.escape(str(text), quote=True)
