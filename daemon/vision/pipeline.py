"""The whole science core on one image: HSI -> segmentations -> uncommon -> interest -> points."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from functools import cached_property, partial

import cv2
import numpy as np

from .aims import aim_entry, aim_points, aimed_map, kind_maps
from .cooccurrence import BAND_PIXELS, Segmentation
from .exact import exact
from .explain import PLANE_NAMES, clauses, explain_points, plain_lines
from .hsi import HSIPlanes, colour_contrast, hue_histogram_rotation, rgb_to_hsi
from .interest import InterestMap, InterestPoint, interest_map, summed_uncommon
from .layers import discount_texture, discount_uncommon, layer_share
from .lines import line_rarity, line_shade
from .nodata import beside, fill, neutral, no_data_mask
from .params import PRESMOOTH_MAX, VisionParams
from .segment import segment_plane
from .shadow import shadow_likelihood
from .texture import texture_rarity
from .uncommon import UncommonWindows, uncommon_map

__all__ = ["NO_TARGET", "Analysis", "analyze"]

NO_TARGET = "no further target: indistinguishable from the view's background"
"""The description of a point whose score cannot be told from the view's background
(``peaks.mark_background``), in place of a confident account of what it found."""


@dataclass(frozen=True)
class Analysis:
    """Everything the pipeline computed for one image (analysed-image pixel coordinates)."""

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
    image: np.ndarray | None = field(default=None, repr=False)
    """The image as given to :func:`analyze`, which :attr:`hsi` is made from again."""
    planes: HSIPlanes | None = field(default=None, repr=False)
    """The H, S, I planes when the analysis kept them (an image up to ``_KEEP_PLANES``)."""
    no_data: np.ndarray | None = field(default=None, repr=False)
    """The no-data left out (found, or given to :func:`analyze`), for :attr:`hsi`."""

    @cached_property
    def hsi(self) -> HSIPlanes:
        """The analysed image's H, S, I planes: those kept, else made again (on a big image
        they are not held through the analysis, for products that may never be asked for)."""
        return _planes(self.planes, self.image, self.params, self.no_data)


@exact
def analyze(
    bgr: np.ndarray,
    params: VisionParams,
    prior: np.ndarray | None = None,
    no_data: np.ndarray | None = None,
) -> Analysis:
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
    no_data : (M, N) bool ndarray, optional
        Pixels known not to be image (a stitched mosaic's uncovered canvas), left out with
        any fill the analysis finds itself (``nodata``), however small.

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
    source = bgr
    bgr, void, hsi = _prepare(bgr, params, no_data)
    valid = None if void is None else ~void
    t1 = time.perf_counter()
    timings["hsi"] = (t1 - t0) * 1e3
    segs = (
        _segment_hue(hsi, valid, params),
        segment_plane(hsi.s, params, mask=valid),
        segment_plane(hsi.i, params, mask=valid),
    )
    t2 = time.perf_counter()
    timings["segment"] = (t2 - t1) * 1e3
    # A big image's planes are let go here and made again where they are read: held, they
    # would sit under every later stage's arrays (4 bytes per pixel).
    kept = hsi if hsi.i.size <= _KEEP_PLANES else None
    del hsi
    shares = [layer_share(seg) for seg in segs] if params.layers > 0 else None
    if shares is None:  # each map is made where it is read: no full-size float map is kept
        maps: list[np.ndarray] | list[UncommonWindows] = [
            UncommonWindows(seg, params) for seg in segs
        ]
        # The whole sum is made for what reshapes it (the shadow gate, a no-data fill, an
        # aim); otherwise the interest map sums a band at a time.
        reshaped = params.shadow_gate > 0 or void is not None or params.aim != "any"
        total = _summed(segs, params) if reshaped else None
    else:
        maps = [
            discount_uncommon(uncommon_map(seg, params), s, params.layers)
            for seg, s in zip(segs, shares, strict=True)
        ]
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
    planes = partial(_planes, kept, source, params, void)
    likeness = None if params.aim == "any" else kind_maps(bgr, planes(), shade, bars)
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
        for p, line, expl in zip(points, plain_lines(points, planes()), explanations, strict=True)
    ]
    timings["explain"] = (time.perf_counter() - t3) * 1e3
    timings["total"] = (time.perf_counter() - t0) * 1e3
    notes = _notes(segs, params, void)
    return Analysis(
        segs, imap, points, explanations, descriptions, params, timings, notes, source, kept, void
    )


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


_KEEP_PLANES = 1 << 22
"""Pixels up to which the analysis keeps the H, S, I planes (at most 16 MB) rather than
making them twice."""


def _prepare(
    bgr: np.ndarray, params: VisionParams, known: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray | None, HSIPlanes]:
    """(the image with any no-data fill made neutral, the fill's mask or None, the H, S, I
    planes of what is segmented); ``known``: no-data the caller knows of."""
    void = _void(no_data_mask(bgr), known)
    if void is not None:  # a mosaic's or a panorama's black fill is not image (``nodata``)
        bgr = fill(bgr, void)
    # Sensor noise is smoothed out of what is segmented only: texture and shade are judged
    # on the image as it came (fine local contrast is what texture rarity measures).
    hsi = _smoothed_hsi(bgr, params.presmooth, params)
    if params.presmooth_colour > 0:  # colour, coarser than brightness, more on a colourful view
        contrast = colour_contrast(hsi.s, None if void is None else ~void)
        colour = min(PRESMOOTH_MAX, params.presmooth_colour * contrast / 100.0)
        if colour > params.presmooth:
            chroma = _smoothed_hsi(bgr, colour, params)
            hsi = hsi._replace(h=chroma.h, s=chroma.s)
    return bgr, void, hsi


def _void(found: np.ndarray | None, known: np.ndarray | None) -> np.ndarray | None:
    """The no-data found and the no-data known together; None when there is none, or when
    nothing else is left (no image to tell it from, as ``nodata.no_data_mask`` says)."""
    if known is None or not known.any():
        return found
    void = known if found is None else found | known
    return None if void.all() else void


def _smoothed_hsi(bgr: np.ndarray, sigma: float, params: VisionParams) -> HSIPlanes:
    """The H, S, I planes of ``bgr`` smoothed by a Gaussian of ``sigma`` (0: as it is)."""
    smooth = cv2.GaussianBlur(bgr, (0, 0), sigma) if sigma > 0 else bgr
    return rgb_to_hsi(smooth, params.grey_saturation, params.hue_min_intensity)


def _segment_hue(hsi: HSIPlanes, valid: np.ndarray | None, params: VisionParams) -> Segmentation:
    """The hue plane's segmentation: rotated so the cut falls in the emptiest hue
    (``hue_rotate``), grey pixels left out or made a class (``hue_grey``)."""
    hue_defined = hsi.hue_defined
    defined = hue_defined if valid is None else hue_defined & valid
    offset = hue_histogram_rotation(hsi.h, defined) if params.hue_rotate else 0
    if params.hue_grey == "unsegmented":
        return segment_plane(hsi.h, params, mask=defined, offset=offset)
    # Grey pixels go to code 0 of the hue rotated by ``offset`` ("zero" rotates by 0; "class"
    # by the emptiest hue, so grey is a class of its own). uint8 arithmetic wraps modulo 256,
    # which is the rotation.
    grey = hue_defined.view(np.uint8) * np.uint8(255)
    del hue_defined, defined
    hue = cv2.bitwise_and(hsi.h + np.uint8(offset), grey)
    del grey
    return segment_plane(hue, params, mask=valid, offset=offset, rotated=True)


@exact
def _planes(
    kept: HSIPlanes | None,
    image: np.ndarray,
    params: VisionParams,
    void: np.ndarray | None = None,
) -> HSIPlanes:
    """The planes kept, else those of ``image`` (with its no-data ``void``) made again."""
    return kept if kept is not None else _prepare(image, params, void)[2]


def _summed(segs: tuple[Segmentation, ...], params: VisionParams) -> np.ndarray:
    """``interest.summed_uncommon`` a band of rows at a time: the same sum, value for value
    (each pixel's is its own labels'), with a band's three float maps instead of the image's
    (12 bytes per pixel)."""
    rows, cols = segs[0].labels.shape
    total = np.empty((rows, cols), np.float32)
    step = max(1, BAND_PIXELS // max(cols, 1))
    for r0 in range(0, rows, step):
        band = np.s_[r0 : r0 + step, :]
        total[band] = summed_uncommon(tuple(seg.window(band) for seg in segs), params)
    return total


def _fit_prior(prior: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """The prior at the analysed image's size; refused unless a finite 2-D map."""
    prior = np.asarray(prior, np.float32)
    if prior.ndim != 2 or prior.size == 0 or not np.isfinite(prior).all():
        raise ValueError(f"a prior must be a finite 2-D map, got shape {prior.shape}")
    if prior.shape != shape:
        prior = cv2.resize(prior, (shape[1], shape[0]), interpolation=cv2.INTER_LINEAR)
    return prior
