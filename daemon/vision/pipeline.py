"""The whole science core on one image: HSI -> segmentations -> uncommon -> interest -> points."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import partial

import cv2
import numpy as np

from .aims import aim_entry, aim_points, aimed_map, kind_maps
from .cooccurrence import Segmentation
from .explain import PLANE_NAMES, clauses, explain_points, plain_lines
from .hsi import HSIPlanes, hue_histogram_rotation, rgb_to_hsi
from .interest import InterestMap, InterestPoint, interest_map, summed_uncommon
from .layers import discount_texture, discount_uncommon, layer_share
from .lines import line_rarity, line_shade
from .nodata import beside, fill, neutral, no_data_mask
from .params import VisionParams
from .segment import segment_plane
from .shadow import shadow_likelihood
from .texture import texture_rarity
from .uncommon import uncommon_map

__all__ = ["NO_TARGET", "Analysis", "analyze"]

NO_TARGET = "no further target: indistinguishable from the view's background"
"""The description of a point whose score cannot be told from the view's background
(``peaks.mark_background``), in place of a confident account of what it found."""


@dataclass(frozen=True)
class Analysis:
    """Everything the pipeline computed for one image (analysed-image pixel coordinates)."""

    hsi: HSIPlanes
    segmentations: tuple[Segmentation, Segmentation, Segmentation]
    interest: InterestMap
    points: list[InterestPoint]
    explanations: list[list[dict]]
    descriptions: list[str]
    """One plain-language line per point (``explain.plain_lines``); :data:`NO_TARGET` for
    a point marked as background."""
    params: VisionParams
    timings_ms: dict[str, float] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    """What the analysis could not do and why, in plain language (``_notes``): a plane of one
    class, a no-data fill left out."""


def analyze(bgr: np.ndarray, params: VisionParams, prior: np.ndarray | None = None) -> Analysis:
    """Find the most uncommon regions of a colour image.

    Parameters
    ----------
    bgr : (M, N, 3) uint8 ndarray
        A frame or a quasi-mosaic, B, G, R order (``daemon.imageio.as_bgr8`` brings any
        decoded image to it). Not modified.
    params : VisionParams
    prior : 2-D ndarray, optional
        Weights on the interest where points are picked (``interest.interest_map``), of any
        size covering the same ground as ``bgr`` (resized to it).

    Returns
    -------
    Analysis
        Points are best first, in (x = column, y = row) pixels of ``bgr``; those whose
        score cannot be told from the view's background are kept, marked ``target=False``
        (``peaks.mark_background``).

    Examples
    --------
    >>> from cyborg.daemon.vision.params import PAPER
    >>> img = np.full((90, 120, 3), (60, 110, 160), np.uint8)    # buff rock
    >>> img[40:50, 80:90] = (40, 160, 40)                          # a green plant
    >>> res = analyze(img, PAPER)
    >>> p = res.points[0]
    >>> abs(p.x - 84.5) < 1 and abs(p.y - 44.5) < 1                # the plant's centre
    True
    """
    if bgr.ndim != 3 or bgr.shape[2] != 3 or bgr.dtype != np.uint8:
        raise ValueError(f"expected (M, N, 3) uint8, got {bgr.shape} {bgr.dtype}")
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    void = no_data_mask(bgr)
    if void is not None:  # a mosaic's or a panorama's black fill is not image (``nodata``)
        bgr = fill(bgr, void)
    valid = None if void is None else ~void
    # Sensor noise is smoothed out of what is segmented only: texture and shade are judged
    # on the image as it came (fine local contrast is what texture rarity measures).
    smooth = cv2.GaussianBlur(bgr, (0, 0), params.presmooth) if params.presmooth > 0 else bgr
    hsi = rgb_to_hsi(smooth, params.grey_saturation, params.hue_min_intensity)
    t1 = time.perf_counter()
    timings["hsi"] = (t1 - t0) * 1e3
    defined = hsi.hue_defined if valid is None else hsi.hue_defined & valid
    hue, hue_mask = hsi.h, valid
    if params.hue_grey == "unsegmented":
        hue_mask = defined
    offset = hue_histogram_rotation(hsi.h, defined) if params.hue_rotate else 0
    if params.hue_grey != "unsegmented":
        # Grey pixels go to code 0 after rotation by ``offset`` ("zero" rotates by 0; "class"
        # by the emptiest hue, so grey is a class of its own). uint8 arithmetic wraps modulo
        # 256, which is the rotation.
        rotation = np.uint8(offset)
        defined = hsi.hue_defined.view(np.uint8) * np.uint8(255)
        hue = cv2.bitwise_and(hsi.h + rotation, defined) - rotation
    segs = (
        segment_plane(hue, params, mask=hue_mask, offset=offset),
        segment_plane(hsi.s, params, mask=valid),
        segment_plane(hsi.i, params, mask=valid),
    )
    t2 = time.perf_counter()
    timings["segment"] = (t2 - t1) * 1e3
    maps = [uncommon_map(seg, params) for seg in segs]
    shares = [layer_share(seg) for seg in segs] if params.layers > 0 else None
    if shares is not None:
        maps = [discount_uncommon(m, s, params.layers) for m, s in zip(maps, shares, strict=True)]
    total = summed_uncommon(segs, params, maps)
    rarity = texture = texture_rarity(bgr, params) if params.texture_weight > 0 else None
    if rarity is not None and shares is not None:
        rarity = texture = discount_texture(rarity, shares, params.layers)
    bars = line_rarity(bgr, params) if params.line_weight > 0 else None
    lines = None if bars is None else cv2.multiply(bars, bars)
    shade = shadow_likelihood(bgr, params) if params.shadow_gate > 0 else None
    if shade is not None:
        # Shade is judged on the image, before any blur: the gate keeps a shadow's rarity
        # out of the interest while the maps and the explanations keep it.
        gate = np.float32(params.shadow_gate)
        lit = 1.0 - gate * shade
        total = cv2.multiply(total, lit)
        texture = None if texture is None else cv2.multiply(texture, lit)
        if lines is not None:  # a line along a shadow is the shadow's rim or its thin end
            lines = cv2.multiply(lines, 1.0 - gate * line_shade(lines, shade))
    if void is not None:  # the fill and its rim score the typical level, as outside the frame
        band = beside(void)
        total, texture, lines = (
            None if m is None else neutral(m, band) for m in (total, texture, lines)
        )
    if prior is not None:
        prior = _fit_prior(prior, bgr.shape[:2])
    imap = interest_map(segs, params, total, texture, prior=prior, line=lines)
    # An aim (``aims``) orders the points by kind; ``any`` leaves them as found.
    likeness = None if params.aim == "any" else kind_maps(bgr, hsi, shade, bars)
    remap = partial(aimed_map, segs, params, total, texture, prior=prior, line=lines)
    points, kinds = aim_points(imap, params, likeness, remap)
    t3 = time.perf_counter()
    timings["interest"] = (t3 - t2) * 1e3
    explanations = explain_points(
        points,
        segs,
        params,
        maps,
        texture=rarity,
        shade=shade,
        layers=shares,
        bars=bars,
        interest=imap,
    )
    for expl, kind in zip(explanations, kinds, strict=bool(kinds)):  # no kinds under ``any``
        expl.append(aim_entry(params.aim, kind))
    descriptions = [
        line + clauses(expl) if p.target else NO_TARGET
        for p, line, expl in zip(points, plain_lines(points, hsi), explanations, strict=True)
    ]
    timings["explain"] = (time.perf_counter() - t3) * 1e3
    timings["total"] = (time.perf_counter() - t0) * 1e3
    notes = _notes(segs, params, void)
    return Analysis(hsi, segs, imap, points, explanations, descriptions, params, timings, notes)


def _notes(
    segs: tuple[Segmentation, ...], params: VisionParams, void: np.ndarray | None
) -> tuple[str, ...]:
    """Plain-language notes: planes whose segmentation found one class (nothing in them is
    uncommon, so with every plane alike the seed's maps alone have no point to give; a
    profile with texture or lines still judges those) and the no-data fill left out.

    >>> from cyborg.daemon.vision.params import DEFAULT, PAPER
    >>> flat = np.full((30, 40, 3), 128, np.uint8)
    >>> _notes(analyze(flat, PAPER).segmentations, PAPER, None)
    ('one class in H, S and I: nothing is uncommon at this resolution',)
    >>> _notes(analyze(flat, DEFAULT).segmentations, DEFAULT, None)
    ('one class in H, S and I: no colour or brightness is uncommon at this resolution',)
    """
    alone = [name for name, seg in zip(PLANE_NAMES, segs, strict=True) if seg.k <= 1]
    notes = []
    if len(alone) == len(segs):
        seen = params.texture_weight > 0 or params.line_weight > 0  # texture, lines judged still
        what = "no colour or brightness" if seen else "nothing"
        notes.append(f"one class in H, S and I: {what} is uncommon at this resolution")
    elif alone:
        planes, them = (alone[0], "it") if len(alone) == 1 else (" and ".join(alone), "them")
        notes.append(f"one class in {planes}: no value in {them} is uncommon at this resolution")
    if void is not None:
        notes.append(
            f"no-data fill ({100 * float(void.mean()):.0f} % of the view, black beyond the "
            "image's edge) left out: never segmented or scored"
        )
    return tuple(notes)


def _fit_prior(prior: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """The prior at the analysed image's size; refused unless a finite 2-D map."""
    prior = np.asarray(prior, np.float32)
    if prior.ndim != 2 or prior.size == 0 or not np.isfinite(prior).all():
        raise ValueError(f"a prior must be a finite 2-D map, got shape {prior.shape}")
    if prior.shape != shape:
        prior = cv2.resize(prior, (shape[1], shape[0]), interpolation=cv2.INTER_LINEAR)
    return prior
