"""Memory across stations: what the session's earlier stations saw at a candidate's place
and scale, so it can be called new or already seen (novelty against history, as rover
science autonomy ranks targets against earlier sols; the seed's authors asked for this
memory when walking closer).

Where. Each station keeps its :class:`~.register.Frame`: how its directions map into the
session's first station's, composed along the walks it was aimed through (300 -> 60 -> 10 m:
the 10 m view is placed in the 60 m one and, through it, in the 300 m one); a station shot
without a new aim (a repeat) stands where the last one stood. So every earlier station of
the session, not only the one aimed from, tells where it saw a new point, and how big: the
point's angular radius divided by the walks between.

What it saw. An earlier station *ranked* the point when one of its targets of comparable
size (within ``_SCALE`` times) covers that place; it *saw* it as distinct as it is now when
its own mosaic, read back from the archive once a session, resolves the place (at least
``_RESOLVE`` pixels of radius) and shows there the same contrast of the patch's core against
its surround (:func:`distinctness`: ΔE, CIE76, so robust to exposure; measured in each
station's own pixels, the same angular patch in far fewer pixels from afar; the best within
half a radius, for the registration's residual).

Novelty, per point: 0 when an earlier station ranked it; else the share of its distinctness
that no earlier station covering and resolving it showed, ``(now - then) / max(now,
DISTINCT)``, the least over them; 1 when none covered or resolved it. Above ``NEW`` it is
"new since" the session's first station; else the clause says where it was seen ("#1 at
st01-300m", "seen at st01-300m"). A repeated view ranks or sees everything again.

Each station also leaves a palette, the 8 main colours of its mosaic in CIE Lab (k-means on
a reduced copy), for the coarse station's steering of the close one (:func:`station_prior`,
the seed's proposal): its interest map, carried into the new mosaic's frame by the same
prediction registration uses, and a neighbourhood around the chosen target weigh the new
station's interest, so what was judged common from afar is de-emphasised and the target's
surroundings favoured.

No-data is nothing seen. What no frame of a registered (stitched) mosaic covers, exactly
black there (``stitch.uncovered``), is no colour of the palette, no part of a patch's core or
surround, and carried into a closer station as ground the earlier one did not see (weighed as
new), not as the level the science scored it at. A butted mosaic's black is left as image:
there it may be a shadow the camera crushed.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace
from typing import Any

import cv2
import numpy as np

from cyborg.protocol.messages import InterestPoint

from ..archive import Archive, ArchiveError
from ..pointing.geometry import MosaicGeometry, SphericalMosaic, pixel_centre
from .approach import Previous, station_image
from .register import Frame, carry
from .stitch import no_data, uncovered

__all__ = [
    "DISTINCT",
    "NEW",
    "NEW_DE",
    "SessionMemory",
    "distinctness",
    "lab_image",
    "station_prior",
]

_LOGGER = logging.getLogger(__name__)

NEW_DE = 20.0
"""ΔE above which a colour counts as not seen before (about twice the difference most
people call clearly different)."""
NEW = 0.5
"""Novelty above which a point is called new: no earlier station showed half of its
distinctness there."""
DISTINCT = 6.0
"""ΔE of core against surround below which a patch is not distinct (a few times the 2.3
people just notice): a plain patch seen plain before is not new for the noise in it."""
_RESOLVE = 1.0
"""Radius, in an earlier station's mosaic pixels, below which it could not resolve a patch."""
_SCALE = 5.0
"""How many times larger or smaller than the new point an earlier target may be and still
be the same one: one leg's walk (300 -> 60 m), for sizes measured from interest maps are
rough (the 60 m stain of a seeded world is 1.7 deg, its 300 m #1 5.5 deg). A detail much
smaller than the earlier target it lies in is judged by what that station saw of it."""
PALETTE = 8
_SAMPLE = 96
"""Longest side of the mosaic copy the palette is learnt on."""


def _lab(bgr: np.ndarray) -> np.ndarray:
    """Float Lab (L 0..100, a, b about -128..127) of uint8 BGR pixels, (..., 3)."""
    lab = cv2.cvtColor(bgr.astype(np.float32) / 255.0, cv2.COLOR_BGR2LAB)
    return lab.reshape(-1, 3)


def lab_image(bgr: np.ndarray, geometry: MosaicGeometry | None = None) -> np.ndarray:
    """Float Lab of a uint8 BGR image, (M, N, 3); NaN where it is the mosaic of a station
    shot as ``geometry`` and shows no-data (:func:`stitch.no_data`)."""
    lab = _lab(bgr).reshape(bgr.shape)
    void = no_data(bgr, geometry)
    if void is not None:
        lab[void] = np.nan
    return lab


def _unseen(plane: np.ndarray, void: np.ndarray) -> np.ndarray:
    """``plane`` (a map of a mosaic, at its size or reduced from it) as float32, NaN on every
    pixel that holds any of the mosaic's no-data ``void``."""
    h, w = plane.shape[:2]
    share = cv2.resize(void.astype(np.float32), (w, h), interpolation=cv2.INTER_AREA)
    return np.where(share > 0, np.float32(np.nan), plane.astype(np.float32))


def distinctness(lab: np.ndarray, x: float, y: float, radius: float) -> float:
    """ΔE between the mean colours of a patch's core and its surround, in the Lab image
    ``lab`` (M, N, 3): the core is the disc of half the ``radius`` (at least a pixel) around
    pixel (x, y) (centres at integers, as the analysis counts them), the surround the ring
    from 1.5 to 2.5 radii; both cut to the image and to its pixels that are not NaN
    (no-data, :func:`lab_image`), 0 when either is left empty."""
    rows, cols = lab.shape[:2]
    core = max(1.0, 0.5 * radius)
    inner = max(core + 1.0, 1.5 * radius)
    outer = inner + max(1.5, radius)
    reach = math.ceil(outer)
    x0, x1 = max(0, round(x) - reach), min(cols, round(x) + reach + 1)
    y0, y1 = max(0, round(y) - reach), min(rows, round(y) + reach + 1)
    ys, xs = np.mgrid[y0:y1, x0:x1]
    dist = np.hypot(xs - x, ys - y)
    window = lab[y0:y1, x0:x1]
    shown = ~np.isnan(window).any(axis=2)
    inside = window[(dist <= core) & shown]
    ring = window[(dist >= inner) & (dist <= outer) & shown]
    if not len(inside) or not len(ring):
        return 0.0
    return float(np.linalg.norm(inside.mean(axis=0) - ring.mean(axis=0)))


@dataclass(frozen=True)
class _Station:
    """What memory keeps of a station: where it stood and looked, what it ranked."""

    id: str
    """``session/name``."""
    frame: Frame
    geometry: MosaicGeometry
    points: tuple[InterestPoint, ...]
    palette: np.ndarray
    """(PALETTE, 3) Lab: its main colours, for :func:`station_prior`."""

    @property
    def name(self) -> str:
        return self.id.partition("/")[2]

    def ranked(self, pan: float, tilt: float, radius: float) -> int | None:
        """The rank of its target of comparable size that covers (pan, tilt), a patch of
        ``radius`` degrees as it saw them, or of whose place that patch covers."""
        for q in self.points:
            size = q.radius_deg or 0.0
            if not q.target or not size / _SCALE <= radius <= size * _SCALE:
                continue
            if math.hypot(pan - q.pan, tilt - q.tilt) <= max(size, radius):
                return q.rank
        return None


@dataclass
class SessionMemory:
    stations: list[_Station] = field(default_factory=list)
    """The session's completed stations, oldest first."""
    mosaics: dict[str, np.ndarray | None] = field(default_factory=dict)
    """Earlier stations' mosaics in Lab (None: unreadable), read from the archive once."""

    def remember(
        self,
        station_id: str,
        mosaic: np.ndarray,
        geometry: MosaicGeometry,
        points: list[InterestPoint],
        previous: Previous | None,
    ) -> None:
        """Keep a completed station: where it stood (aimed from ``previous``), how its
        ``mosaic`` maps to angles, its ranked ``points`` and its palette."""
        rows, cols = mosaic.shape[:2]
        scale = _SAMPLE / max(rows, cols)
        f = min(scale, 1.0)
        small = cv2.resize(mosaic, None, fx=f, fy=f, interpolation=cv2.INTER_AREA)
        lab = _lab(small)
        void = no_data(mosaic, geometry)
        if void is not None:  # no colour of the outcrop, nor blended into one
            lab = lab[np.isfinite(_unseen(small[..., 0], void)).ravel()]
        k = min(PALETTE, len(lab))
        criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 20, 0.5)
        cv2.setRNGSeed(0)
        _, _, centres = cv2.kmeans(lab, k, None, criteria, 2, cv2.KMEANS_PP_CENTERS)
        frame = self._frame(previous)
        self.stations.append(_Station(station_id, frame, geometry, tuple(points), centres))

    def palettes(self) -> list[np.ndarray]:
        """The earlier stations' palettes, (PALETTE, 3) Lab each, oldest first."""
        return [s.palette for s in self.stations]

    def recall(
        self,
        points: list[InterestPoint],
        mosaic: np.ndarray,
        geometry: MosaicGeometry,
        previous: Previous | None,
        archive: Archive,
    ) -> list[InterestPoint]:
        """The ``points`` of a station (its ``mosaic`` shot as ``geometry``, aimed from
        ``previous``) judged against what the session's earlier stations saw there (module
        doc): each with its novelty and its explanation's clause ("#1 at st01-300m", "seen at
        st01-300m" or "new since st01-300m"). Unchanged at a session's first station, and a
        point that is no target (``target`` false)."""
        if not self.stations:
            return points
        frame, lab = self._frame(previous), lab_image(mosaic, geometry)
        out = []
        for p in points:
            if not p.target:  # no further target: nothing to call new or seen
                out.append(p)
                continue
            novelty, clause = self._judge(p, frame, lab, geometry, archive)
            why = "; ".join(part for part in (p.why, clause) if part)
            out.append(replace(p, why=why, novelty=round(novelty, 3)))
        return out

    def prior(
        self,
        previous: Previous | None,
        archive: Archive,
        geometry: MosaicGeometry,
        mosaic: np.ndarray,
        weight: float,
    ) -> tuple[np.ndarray | None, dict[str, Any] | None]:
        """The weights the station this one was aimed from puts on its interest
        (:func:`station_prior`, ``survey.memory`` = ``weight``) and the manifest's ``memory``
        record. No prior for a first station or with the option off (and no record), nor
        when the earlier interest cannot be read (the record says why)."""
        if weight <= 0 or previous is None:
            return None, None
        try:
            interest = previous.image(
                archive, "analysis/interest.png", cv2.IMREAD_GRAYSCALE, "interest map"
            )
            old_geo = previous.geometry(archive)
            if isinstance(old_geo, SphericalMosaic):  # its no-data was not seen (module doc)
                old = previous.image(archive, "mosaic.png", cv2.IMREAD_COLOR, "mosaic")
                interest = _unseen(interest, uncovered(old))
            prior = station_prior(
                interest,
                old_geo,
                geometry,
                target=previous.target,
                radius_deg=previous.radius_deg,
                walk=previous.walk,
                weight=weight,
                mosaic=mosaic,
                palettes=self.palettes(),
            )
        except (ArchiveError, cv2.error, ValueError) as exc:
            return None, {"from": previous.station, "note": f"no prior: {exc}"}
        return prior, {"from": previous.station, "weight": weight}

    def clear(self) -> None:
        self.stations.clear()
        self.mosaics.clear()

    def _frame(self, previous: Previous | None) -> Frame:
        """Where a station aimed from ``previous`` stands: walked from that station, else
        where the last station stood (shot again without a new aim), else the reference."""
        known = {s.id: s.frame for s in self.stations}
        if previous is not None and previous.station in known:
            return known[previous.station].walked(previous.target, previous.walk)
        return self.stations[-1].frame if self.stations else Frame()

    def _judge(
        self,
        p: InterestPoint,
        frame: Frame,
        lab: np.ndarray,
        geometry: MosaicGeometry,
        archive: Archive,
    ) -> tuple[float, str]:
        """(novelty, clause) of point ``p`` of a station standing at ``frame``."""
        radius = p.radius_deg or geometry.degrees_per_pixel
        places = [
            (s, *frame.into(s.frame, p.pan, p.tilt), radius * frame.scale / s.frame.scale)
            for s in self.stations
        ]
        for s, pan, tilt, there in places:
            rank = s.ranked(pan, tilt, there)
            if rank is not None:
                return 0.0, f"#{rank} at {s.name}"
        now = distinctness(lab, p.x, p.y, radius / geometry.degrees_per_pixel)
        best: tuple[float, str] | None = None
        for s, pan, tilt, there in places:
            then = self._seen(s, pan, tilt, there, archive)
            if then is not None:
                share = min(1.0, max(0.0, (now - then) / max(now, DISTINCT)))
                if best is None or share < best[0]:
                    best = (share, s.name)
        if best is None or best[0] > NEW:
            return (1.0 if best is None else best[0]), f"new since {self.stations[0].name}"
        return best[0], f"seen at {best[1]}"

    def _seen(
        self, s: _Station, pan: float, tilt: float, radius: float, archive: Archive
    ) -> float | None:
        """How distinct station ``s`` saw the patch of ``radius`` degrees at (pan, tilt) (its
        directions): the best within half a radius; None where it did not look, could not
        resolve the patch or its mosaic cannot be read."""
        pixels = radius / s.geometry.degrees_per_pixel
        place = s.geometry.to_mosaic(pan, tilt)
        if pixels < _RESOLVE or place is None:
            return None
        lab = self._mosaic(s, archive)
        if lab is None:
            return None
        x, y, step = place[0] - 0.5, place[1] - 0.5, 0.5 * pixels
        return max(
            distinctness(lab, x + dx * step, y + dy * step, pixels)
            for dx in (-1, 0, 1)
            for dy in (-1, 0, 1)
        )

    def _mosaic(self, s: _Station, archive: Archive) -> np.ndarray | None:
        """Station ``s``'s mosaic in Lab, (M, N, 3): read from the archive at its first use
        in the session (None, and logged, when it cannot be read)."""
        if s.id not in self.mosaics:
            try:
                bgr = station_image(archive, s.id, "mosaic.png", cv2.IMREAD_COLOR, "mosaic")
                self.mosaics[s.id] = lab_image(bgr, s.geometry)
            except (ArchiveError, cv2.error) as exc:
                _LOGGER.warning("memory: station %s not judged against: %s", s.id, exc)
                self.mosaics[s.id] = None
        return self.mosaics[s.id]


_PRIOR = 96
"""Longest side of the grid the prior is carried on (it is smooth: a coarse look's map)."""
_NEAR = 0.5
"""The favoured neighbourhood's Gaussian sigma, in radii of the chosen target: where the
earlier station placed the target, to within how well a patch's centre is known, not the
target's whole extent. At the last station the whole view lies inside the target, and a
neighbourhood of its radius favours nothing there: the stain's bright rim, at the edge of
the 10 m view, won over its core in 5 more of 90 bench approaches (77 against 82)."""
_ELSEWHERE = 0.25
"""The favour, as a share of the chosen target's, that ground judged interesting from afar
keeps away from the target: the operator chose this target, not the others. At 1 (every
region judged interesting favoured as much as the target) the stain's rim, the brightest
ring of the 60 m interest, beat its core at 10 m in 2 more of 90 approaches (80 against
82)."""


def station_prior(
    interest: np.ndarray,
    old_geo: MosaicGeometry,
    new_geo: MosaicGeometry,
    *,
    target: tuple[float, float],
    radius_deg: float,
    walk: float,
    weight: float,
    mosaic: np.ndarray | None = None,
    palettes: list[np.ndarray] | None = None,
) -> np.ndarray:
    """Weights for the new station's interest, (h, w) float32 on a grid of the new mosaic:
    ``1 - weight + weight x max(near, _ELSEWHERE x judged x fresh)``.

    ``judged`` is the earlier interest (``interest``, over the earlier mosaic; NaN where it
    had no data) carried into the new frame and scaled to its maximum, 1 where the earlier
    station saw nothing (new ground is not common ground); ``near`` a Gaussian around the
    chosen ``target`` of sigma ``_NEAR`` times its radius as seen now (``radius_deg`` from
    the earlier station, times ``walk``); ``fresh`` how far the new ``mosaic``'s colour at
    each cell lies from the nearest colour of the earlier stations' ``palettes``
    (:meth:`SessionMemory.palettes`),
    ΔE / ``NEW_DE`` up to 1 (1 everywhere without them). So the chosen target's place counts
    fully; what was judged interesting elsewhere, a quarter as much, and less the more its
    colour was one of the main colours from afar (a bed cut by the new frame's edge is rare in
    the frame, not on the outcrop); what was judged common, least.
    """
    width, height = new_geo.size
    scale = min(1.0, _PRIOR / max(width, height))
    size = (max(2, round(width * scale)), max(2, round(height * scale)))
    judged = carry(interest, old_geo, new_geo, target=target, walk=walk, size=size)
    top = float(np.nanmax(judged)) if np.isfinite(judged).any() else 0.0
    judged = np.where(np.isfinite(judged), judged / top if top > 0 else 0.0, 1.0)
    if mosaic is not None and palettes:
        lab = _lab(cv2.resize(mosaic, size, interpolation=cv2.INTER_AREA))
        known = np.concatenate(palettes)
        delta = np.sqrt(((lab[:, None, :] - known[None]) ** 2).sum(axis=2)).min(axis=1)
        judged = judged * np.clip(delta / NEW_DE, 0.0, 1.0).reshape(judged.shape)
    near = np.zeros_like(judged)
    centre = new_geo.to_mosaic(*target)
    if centre is not None:
        deg_per_px = new_geo.degrees_per_pixel / scale
        sigma = max(_NEAR * radius_deg * walk / deg_per_px, 1.0)
        ys, xs = np.mgrid[0 : size[1], 0 : size[0]]
        dx, dy = pixel_centre(xs) - centre[0] * scale, pixel_centre(ys) - centre[1] * scale
        dist2 = dx**2 + dy**2
        near = np.exp(-dist2 / (2.0 * sigma * sigma))
    return ((1.0 - weight) + weight * np.maximum(near, _ELSEWHERE * judged)).astype(np.float32)
