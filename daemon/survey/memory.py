"""Memory across stations: what the session's earlier stations showed, so a candidate can be
called new or already seen (novelty against history, as rover science autonomy ranks
targets against earlier sols; the seed's authors asked for this memory when walking closer).

Each station leaves a palette: the 8 main colours of its mosaic in CIE Lab (k-means on a
reduced copy). A new point's novelty is the colour difference (ΔE, CIE76) from its patch's
colour to the nearest colour any earlier station showed: small, the same stuff seen from
further away; large, something the walk has revealed.

The coarse station also steers the close one (:func:`station_prior`, the seed's proposal):
its interest map, carried into the new mosaic's frame by the same prediction registration
uses, and a neighbourhood around the chosen target weigh the new station's interest, so
what was judged common from afar is de-emphasised and the target's surroundings favoured.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import cv2
import numpy as np

from cyborg.protocol.messages import InterestPoint

from ..archive import Archive, ArchiveError
from ..pointing.geometry import MosaicGeometry, pixel_centre
from .approach import Previous
from .register import carry

__all__ = ["NEW_DE", "SessionMemory", "phrase", "station_prior"]

NEW_DE = 20.0
"""ΔE above which a colour counts as not seen before (about twice the difference most
people call clearly different)."""
PALETTE = 8
_SAMPLE = 96
"""Longest side of the mosaic copy the palette is learnt on."""


def _lab(bgr: np.ndarray) -> np.ndarray:
    """Float Lab (L 0..100, a, b about -128..127) of uint8 BGR pixels, (..., 3)."""
    lab = cv2.cvtColor(bgr.astype(np.float32) / 255.0, cv2.COLOR_BGR2LAB)
    return lab.reshape(-1, 3)


@dataclass
class SessionMemory:
    stations: list[tuple[str, np.ndarray]] = field(default_factory=list)
    """(station name, its palette: (PALETTE, 3) Lab)."""

    def remember(self, station: str, mosaic: np.ndarray) -> None:
        rows, cols = mosaic.shape[:2]
        scale = _SAMPLE / max(rows, cols)
        f = min(scale, 1.0)
        small = cv2.resize(mosaic, None, fx=f, fy=f, interpolation=cv2.INTER_AREA)
        lab = _lab(small)
        k = min(PALETTE, len(lab))
        criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 20, 0.5)
        cv2.setRNGSeed(0)
        _, _, centres = cv2.kmeans(lab, k, None, criteria, 2, cv2.KMEANS_PP_CENTERS)
        self.stations.append((station, centres))

    def novelty(
        self, mosaic: np.ndarray, x: float, y: float, radius: float
    ) -> tuple[float, str] | None:
        """(ΔE to the nearest colour seen before, the station that showed it) for the patch
        of ``radius`` pixels around (x, y); None before any station was remembered."""
        if not self.stations:
            return None
        rows, cols = mosaic.shape[:2]
        r = max(1, round(radius * 0.7))  # the patch's core, not its rim
        x0, x1 = max(0, round(x) - r), min(cols, round(x) + r + 1)
        y0, y1 = max(0, round(y) - r), min(rows, round(y) + r + 1)
        colour = _lab(mosaic[y0:y1, x0:x1]).mean(axis=0)
        best = min(
            (float(np.linalg.norm(palette - colour, axis=1).min()), name)
            for name, palette in self.stations
        )
        return best

    def palettes(self) -> list[np.ndarray]:
        """The earlier stations' palettes, (PALETTE, 3) Lab each, oldest first."""
        return [palette for _, palette in self.stations]

    def recall(
        self, points: list[InterestPoint], radii: dict[int, float], mosaic: np.ndarray
    ) -> list[InterestPoint]:
        """Each point (of pixel radius ``radii[rank]``) against what the session's earlier
        stations showed: its novelty, and a clause for its explanation ("new since
        st01-300m" or "seen at st02-60m")."""
        if not self.stations:
            return points
        first = self.stations[0][0]
        out = []
        for p in points:
            found = self.novelty(mosaic, p.x, p.y, radii.get(p.rank, 4.0))
            why = "; ".join(part for part in (p.why, phrase(found, first)) if part)
            out.append(replace(p, why=why, novelty=round(found[0], 2) if found else None))
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
            prior = station_prior(
                interest,
                previous.geometry(archive),
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


def phrase(novelty: tuple[float, str] | None, first: str) -> str:
    """The explanation's clause: ``new since st01-300m`` or ``seen at st01-300m``."""
    if novelty is None:
        return ""
    delta, station = novelty
    return f"new since {first}" if delta > NEW_DE else f"seen at {station}"


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

    ``judged`` is the earlier interest (``interest``, over the earlier mosaic) carried into
    the new frame and scaled to its maximum, 1 where the earlier station saw nothing (new
    ground is not common ground); ``near`` a Gaussian around the chosen ``target`` of
    sigma ``_NEAR`` times its radius as seen now (``radius_deg`` from the earlier station,
    times ``walk``); ``fresh`` how far the new ``mosaic``'s colour at each cell lies from the
    nearest colour of the earlier stations' ``palettes`` (:meth:`SessionMemory.palettes`),
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
