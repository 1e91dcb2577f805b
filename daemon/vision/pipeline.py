"""The whole science core on one image: HSI -> segmentations -> uncommon -> interest -> points."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import cv2
import numpy as np

from .cooccurrence import Segmentation
from .explain import clauses, explain_points, plain_lines
from .hsi import HSIPlanes, hue_histogram_rotation, rgb_to_hsi
from .interest import InterestMap, InterestPoint, interest_map, summed_uncommon
from .layers import discount_texture, discount_uncommon, layer_share
from .lines import line_rarity, line_shade
from .params import VisionParams
from .peaks import find_points, mark_background
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
    # Sensor noise is smoothed out of what is segmented only: texture and shade are judged
    # on the image as it came (fine local contrast is what texture rarity measures).
    smooth = cv2.GaussianBlur(bgr, (0, 0), params.presmooth) if params.presmooth > 0 else bgr
    hsi = rgb_to_hsi(smooth, params.grey_saturation, params.hue_min_intensity)
    t1 = time.perf_counter()
    timings["hsi"] = (t1 - t0) * 1e3
    hue, hue_mask = hsi.h, None
    if params.hue_grey == "unsegmented":
        hue_mask = hsi.hue_defined
    offset = hue_histogram_rotation(hsi.h, hsi.hue_defined) if params.hue_rotate else 0
    if params.hue_grey != "unsegmented":
        # Grey pixels go to code 0 after rotation by ``offset`` ("zero" rotates by 0; "class"
        # by the emptiest hue, so grey is a class of its own). uint8 arithmetic wraps modulo
        # 256, which is the rotation.
        rotation = np.uint8(offset)
        defined = hsi.hue_defined.view(np.uint8) * np.uint8(255)
        hue = cv2.bitwise_and(hsi.h + rotation, defined) - rotation
    segs = (
        segment_plane(hue, params, mask=hue_mask, offset=offset),
        segment_plane(hsi.s, params),
        segment_plane(hsi.i, params),
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
    if prior is not None:
        prior = _fit_prior(prior, bgr.shape[:2])
    imap = interest_map(segs, params, total, texture, prior=prior, line=lines)
    points = mark_background(imap, find_points(imap, params))
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
    descriptions = [
        line + clauses(expl) if p.target else NO_TARGET
        for p, line, expl in zip(points, plain_lines(points, hsi), explanations, strict=True)
    ]
    timings["explain"] = (time.perf_counter() - t3) * 1e3
    timings["total"] = (time.perf_counter() - t0) * 1e3
    return Analysis(hsi, segs, imap, points, explanations, descriptions, params, timings)


def _fit_prior(prior: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """The prior at the analysed image's size; refused unless a finite 2-D map."""
    prior = np.asarray(prior, np.float32)
    if prior.ndim != 2 or prior.size == 0 or not np.isfinite(prior).all():
        raise ValueError(f"a prior must be a finite 2-D map, got shape {prior.shape}")
    if prior.shape != shape:
        prior = cv2.resize(prior, (shape[1], shape[0]), interpolation=cv2.INTER_LINEAR)
    return prior
