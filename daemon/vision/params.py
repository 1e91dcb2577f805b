"""Every tunable choice of the science core, with the named profiles.

The seed papers state only a few numbers (H/S/I planes, <= 8 classes, rank-of-area uncommon
map, unweighted sum, blur B = 10 px, top 3 peaks). Everything else is a named field here so
that the faithful ``paper`` profile and the improved ``default`` profile can be compared in
one benchmark run.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import types
import typing
from dataclasses import dataclass
from typing import Any, Literal

from cyborg.protocol.aims import parse_aim

UncommonMode = Literal["rank", "spread", "surprisal"]
BlurMode = Literal["sigma", "fwhm"]
HueGrey = Literal["zero", "unsegmented", "class"]
ClassShape = Literal["block", "disc"]


@dataclass(frozen=True)
class VisionParams:
    """Parameters of the uncommon-map interest pipeline (see docs/science.md)."""

    # Input conditioning
    presmooth: float = 0.0
    """Gaussian sigma (pixels) applied to the colour image before HSI, so before segmentation
    only (texture and shade see the image as it came); 0 = off. Each pixel's class is voted
    by its own 4 neighbour pairs, so sensor noise flips pixels between classes and a small
    class in or out of existence from one look to the next."""
    presmooth_colour: float = 0.0
    """When > 0, H and S are pre-smoothed with this sigma per 100 codes of the view's colour
    contrast (``hsi.colour_contrast``) where that exceeds ``presmooth`` (up to
    ``PRESMOOTH_MAX``): a camera's colour is coarser than its brightness (a Bayer mosaic, a
    JPEG's half-resolution colour) and its block and ringing errors grow with the colour
    edges, so plants on soil swap their hue classes between looks; a grey view's chroma is
    nothing but noise, which more smoothing would only gather into blobs. 0: off, in every
    profile: at 2.0, repeat@1 through a camera's JPEG rises on plants 82.8 -> 93.1 % but
    falls on Mars rocks one image in 56 (``docs/benchmarks.md``), so it is a camera's choice
    (``--set presmooth_colour=2``), not yet the default's."""

    # HSI conversion
    grey_saturation: int = 32
    """S (0..255) below which hue is undefined (grey pixel)."""
    hue_min_intensity: int = 0
    """I (0..255) below which hue is undefined too: hue noise grows as 1 / I in the dark."""
    hue_grey: HueGrey = "zero"
    """Hue of grey pixels (S < ``grey_saturation``). zero: H = 0, as 2004-era code did; unsegmented:
    kept out of the hue segmentation; class: given the emptiest hue code, so grey is a hue class of
    its own whose rarity counts like any other (a white vein in red rock is rare in H too)."""
    hue_rotate: bool = False
    """Rotate hue so the 0/360 cut falls in the emptiest hue bin (red beds straddle the cut)."""

    # Co-occurrence histogram
    cooc_max_pairs: int = 1 << 22
    """Above this many neighbour pairs the histogram is estimated on a regular row lattice."""
    cooc_sigma: float = 3.0
    """Gaussian smoothing of the 256x256 histogram, in bins."""
    diag_band: int = 1
    """Diagonal profile d(g) sums cells with |i - j| <= diag_band."""

    # Classes (peaks on the diagonal)
    class_shape: ClassShape = "block"
    """block: values between the valleys around a peak (Haddon & Boyce); disc: a disc of
    radius ``radius_scale`` x HWHM around the peak (see ``cooccurrence``)."""
    max_classes: int = 8
    min_class_fraction: float = 0.005
    """A class holding less than this fraction of the pairs (its block's square, or its
    disc's diagonal mass) is not a class; a light block merges into a neighbour."""
    min_persistence: float = 0.5
    """block: a diagonal maximum is a class only if the profile falls by this fraction of the
    maximum's own height before it meets a higher one: a ripple on a noisy peak is no class,
    a small peak of its own (a stain of 1 % of the pixels) is one however low."""
    radius_scale: float = 1.0
    radius_min: int = 3
    radius_max: int = 16
    """Class disc radius = radius_scale x the half-width at half-maximum of its diagonal
    peak, clipped to [radius_min, radius_max] bins. The HWHM is 1.18 sigma of a region's
    values, so a disc of that radius holds only half of its noisy neighbour pairs."""
    min_votes: int = 3
    """A pixel joins a class when this many of its 4 neighbour pairs fall in the class disc."""
    relax_passes: int = 0
    """Passes that let unsegmented pixels join the class of >= 2 labelled neighbours."""

    # Uncommon map
    uncommon: UncommonMode = "spread"
    """spread: the area rank reversed linearly, largest class 1 .. rarest 8, as the seed states
    it; rank: 1 = largest .. K (the rarest of K < 8 classes scores K); surprisal: 1..8 by log
    area."""
    surprisal_span: float = 1000.0
    """surprisal: a class this many times smaller than the largest one scores 8."""
    value_rarity: float = 0.0
    """Weight of the value's own rarity, added to its class's score on segmented pixels:
    the surprisal of the value in the diagonal profile (the density of region interiors),
    0 at the commonest value .. 7 at ``surprisal_span`` times rarer. Classes are coarse
    (<= 8 a plane); this grades the tail of a class, where a crack or a pit in one broad
    class of rock lies."""
    plane_weights: tuple[float, float, float] = (1.0, 1.0, 1.0)
    """Weights of the H, S, I uncommon maps in the interest sum."""
    layers: float = 0.0
    """Share of a layer's rarity taken away (``layers``): a class region running across the
    view from side to side, thicker than a line, is a bed, the outcrop's structure rather
    than a thing on it, however thin and so rare its class; texture along its contacts
    loses half as much. 0: every class counts for its area alone, as in the seed."""

    # Texture rarity (``texture``), fused with the uncommon interest
    texture_weight: float = 0.0
    """Weight of texture rarity against the uncommon interest (0: the seed's H, S, I only).
    Both blurred maps are put on one scale first: 0 at their median, 1 at their 99.5th
    percentile (``interest.fuse``)."""
    texture_scales: tuple[float, ...] = (1.5, 4.0)
    """Gaussian sigmas (analysed pixels) of the local contrast descriptors, finest first."""
    texture_surround: float = 16.0
    """Gaussian sigma (analysed pixels) of the surroundings brightness is measured against."""
    texture_trim: float = 0.25
    """Share of pixels each concentration step leaves out of the robust texture model."""
    texture_steps: int = 2
    """Concentration steps of the robust fit (0: plain mean and covariance)."""
    texture_blur: float = 2.0
    """Texture rarity is blurred with this many times the interest sigma: texture is a
    property of an area, and per-pixel rarity is speckled."""
    fused_isotropy: float = 0.0
    """``isotropy`` applied once more to the fused map (texture rarity has none of its own)."""

    # Line rarity (``lines``): veins and cracks, not bed contacts
    line_weight: float = 0.0
    """Weight of line rarity, added after roundness (a vein is a line, and roundness is what
    keeps lines down): its blurred map is 0 at its median and 1 at its 99.5th percentile, or
    at ``interest._NO_LINE`` where the view holds no line that strong. 0: off."""
    line_width: float = 1.0
    """Half-width (analysed pixels) of the lines looked for: a line up to about 2 x 1 + 1 = 3
    px wide is a bar against the rock 3 px to either side; a ledge shadow's thicker body is
    not."""
    line_length: float = 4.0
    """Half-length (analysed pixels) of the segment a line is averaged along. Up to 4 each
    orientation's kernel fits 9 x 9, which OpenCV applies directly (a few ms for all eight at
    the working size)."""

    # Shadow gate (``shadow``): the seed's "structural shadow"
    shadow_gate: float = 0.0
    """Share of a pixel's uncommon and texture interest taken away by its shadow likelihood
    (0: shadows count like anything else, as in the seed; 1: a certain shadow counts 0)."""
    shadow_tint: tuple[float, float] = (0.32, 0.12)
    """How going from sun to shade moves a surface's log(B / R) and log(G / R): the shade is
    lit by the bluer sky alone. The direction matters, not the length; a pure darkening is
    accepted too."""
    shadow_surround: float = 6.0
    """Gaussian sigma (analysed pixels) of the lit rock a pixel is compared with: wider than a
    ledge shadow is thick, narrower than a bed, so a shadow on a bed contact is compared with
    its own bed."""

    # Interest map and points
    blur: float = 10.0
    """B, in analysed-image pixels."""
    blur_fraction: float = 0.0
    """When > 0, B is this fraction of the analysed image's diagonal instead of ``blur``:
    the same outcrop gives the same points at any resolution."""
    blur_mode: BlurMode = "fwhm"
    """sigma: B is the Gaussian sigma; fwhm: B is the full width at half maximum."""
    isotropy: float = 0.0
    """Share of the blurred interest that depends on the shape of its surroundings: the
    score is the B-blurred interest (above the image's median) x (1 - isotropy + isotropy x
    iso), iso = lambda_small / lambda_large of the map's curvature at twice B (1 on a round
    patch, 0 along a ridge). Long ledge shadows and bed contacts, rare only along their
    length, lose their lead over compact patches; a long target rare enough still counts."""
    wide_scale: float = 0.0
    """When > 0, the uncommon interest is also blurred with this many times B's sigma, scaled
    by its roundness (``isotropy``), weighted 1 + ``texture_weight`` and kept where it is
    higher than the map (``interest``): a compact area of rare colour tens of pixels across
    scores as a whole at its own scale. 0: one scale, as the seed."""
    valley: float = 0.0
    """Two peaks are one target unless the map falls below this fraction of the lower one
    between them (0: only the separation keeps points apart, as the seed did)."""
    bands: float = 0.0
    """With ``valley`` > 0, exponent of the discount on a peak whose patch (above half its
    height) is a band: elongated past 5 : 1 and wider than the blur, a bed, the sky or a
    ledge's shadow rather than a thing on the outcrop (``peaks.band_discount``). 0: no
    discount."""
    frame: float = 0.0
    """With ``valley`` > 0, exponent of the discount on a peak by the share of its patch
    (above half its height) within 1.5 blur sigmas of the frame (``peaks.frame_share``):
    a bed or a rock the frame cuts down to a sliver is mostly out of view, and a class the
    frame truncates looks rarer than it is. 0: no discount."""
    top_n: int = 3
    min_distance: float | None = None
    """Minimum distance between points (pixels); None means B."""
    max_pixels: int = 0
    """Analyse images above this many pixels at a reduced size (0: never). The points are
    mapped back to the input; a 12 MP photo needs no ``--downsample``."""
    exact_blur: bool = False
    """Blur at full resolution instead of on the band-limited (decimated) grid."""

    # Aim of study (``aims``)
    aim: str = "any"
    """What the station is after, ``KIND[+EXCLUSION...]`` (``protocol.aims``, ``aims``): points
    of the sought kind (dark, bright, colour) come first, excluded kinds (no-vegetation,
    no-sky) last, and the science's own best point is always among the ``top_n``. Kept in
    canonical form, so result.json records one spelling per aim. any: the science's own
    ranking, untouched."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "aim", parse_aim(self.aim).text)
        if not 1 <= self.max_classes <= 8:
            raise ValueError(f"max_classes must be 1..8, got {self.max_classes}")
        if not 1 <= self.min_votes <= 4:
            raise ValueError(f"min_votes must be 1..4, got {self.min_votes}")
        if not 1 <= self.radius_min <= self.radius_max <= 64:
            raise ValueError("need 1 <= radius_min <= radius_max <= 64")
        if self.blur <= 0 or self.top_n < 0 or self.cooc_sigma < 0 or self.presmooth < 0:
            raise ValueError("blur must be > 0; top_n, cooc_sigma, presmooth >= 0")
        if self.presmooth_colour < 0:
            raise ValueError("presmooth_colour must be >= 0")
        if self.radius_scale <= 0:
            raise ValueError("radius_scale must be > 0")
        if self.uncommon not in ("rank", "spread", "surprisal"):
            raise ValueError(f"unknown uncommon mode {self.uncommon!r}")
        if self.class_shape not in ("block", "disc"):
            raise ValueError(f"unknown class shape {self.class_shape!r}")
        if not 0 <= self.min_persistence < 1:
            raise ValueError("min_persistence must be in [0, 1)")
        if self.hue_grey not in ("zero", "unsegmented", "class"):
            raise ValueError(f"unknown hue_grey mode {self.hue_grey!r}")
        if self.blur_fraction < 0 or self.value_rarity < 0 or not 0 <= self.isotropy <= 1:
            raise ValueError("blur_fraction, value_rarity >= 0; isotropy in [0, 1]")
        if not (self.wide_scale == 0 or 1 < self.wide_scale < math.inf):
            raise ValueError(f"wide_scale must be 0 or above 1, got {self.wide_scale}")
        if not 0 <= self.valley < 1 or self.max_pixels < 0 or min(self.bands, self.frame) < 0:
            raise ValueError("valley in [0, 1), max_pixels >= 0, bands and frame >= 0")
        if self.blur_mode not in ("sigma", "fwhm"):
            raise ValueError(f"unknown blur mode {self.blur_mode!r}")
        if self.texture_weight < 0 or self.texture_blur <= 0 or not 0 <= self.fused_isotropy <= 1:
            raise ValueError("texture_weight >= 0, texture_blur > 0, fused_isotropy in [0, 1]")
        if not self.texture_scales or min(self.texture_scales) <= 0 or self.texture_steps < 0:
            raise ValueError("texture_scales must be positive sigmas; texture_steps >= 0")
        if self.texture_surround <= max(self.texture_scales):
            raise ValueError("texture_surround must exceed the largest texture scale")
        if not 0 <= self.texture_trim < 1:
            raise ValueError("texture_trim must be in [0, 1)")
        line = (self.line_weight, self.line_width, self.line_length)
        if not (all(map(math.isfinite, line)) and line[0] >= 0 and line[1] > 0 and line[2] >= 1):
            raise ValueError(
                f"need finite line_weight >= 0, line_width > 0, line_length >= 1: {line}"
            )
        if not 0 <= self.shadow_gate <= 1 or self.shadow_surround <= 0:
            raise ValueError("shadow_gate must be in [0, 1]; shadow_surround > 0")
        if len(self.shadow_tint) != 2 or not 0 < math.hypot(*self.shadow_tint) < math.inf:
            raise ValueError("shadow_tint needs two finite log ratios, not both 0")
        if not 0 <= self.layers <= 1:
            raise ValueError(f"layers must be in [0, 1], got {self.layers}")
        if len(self.plane_weights) != 3 or min(self.plane_weights) < 0:
            raise ValueError("plane_weights needs three non-negative weights")

    def sigma(self, shape: tuple[int, int]) -> float:
        """Gaussian sigma of the interest blur, in pixels of an image of this shape."""
        b = self.blur_fraction * math.hypot(*shape) if self.blur_fraction > 0 else self.blur
        return b if self.blur_mode == "sigma" else b / 2.3548

    def separation(self, shape: tuple[int, int]) -> float:
        """Minimum distance between interest points, in pixels of an image of this shape."""
        if self.min_distance is not None:
            return self.min_distance
        return self.blur_fraction * math.hypot(*shape) if self.blur_fraction > 0 else self.blur

    def replace(self, **changes: Any) -> VisionParams:
        """Return a copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


PRESMOOTH_MAX = 2.0
"""Largest pre-smoothing sigma (analysed pixels) the colour contrast sets: a wider one would
blur away the small targets the blur B still resolves."""

PAPER = VisionParams()
"""The seed's stated choices (H, S, I; <= 8 classes; rank uncommon map; unweighted sum;
B = 10 px; top 3), and for what it leaves open, Haddon & Boyce's reading measured on the
seed's own case (``sim.regimes.seed_cliff``, 108x192, two wet stains):

* classes are blocks of values between valleys of the diagonal profile (persistence >= 50 %
  of a maximum's height, >= 0.5 % of the pairs; histogram smoothed by 3 bins), so regions are
  coherent and only boundaries stay unsegmented (disc classes leave most of each plane
  unsegmented);
* hue is undefined (H = 0, as 2004-era code did) below S = 32 of 255: on pale rock hue is
  sensor noise;
* the rank is reversed linearly so the largest class scores 1 and the rarest 8 whatever the
  number of classes K, which is how the seed states it (``rank``, rarest = K, fits that
  statement only at K = 8);
* B is the blur's full width at half maximum (sigma 4.25 px): read as sigma it smears a stain
  of ~10 px into the bed-scale structure.
"""

UNCOMMON = VisionParams(
    grey_saturation=5,
    hue_grey="class",
    hue_rotate=True,
    cooc_sigma=2.0,
    min_persistence=0.2,
    min_votes=2,
    relax_passes=1,
    min_class_fraction=0.0002,
    uncommon="surprisal",
    value_rarity=0.5,
    blur_mode="sigma",
    blur_fraction=0.008,
    isotropy=0.75,
    valley=0.4,
    max_pixels=1 << 17,
)
"""Our best variant of the seed's method alone (H, S, I uncommon maps, no texture): the
fastest profile, and the best on small colour targets on layered rock. Its departures from
``PAPER`` (chosen on tuning scenes and images, reported on others: ``docs/science-log.md``):

* the same coherent block segmentation, but 2 of 4 neighbour pairs suffice, one relaxation
  pass and classes down to 0.02 % of the pairs, so thin veins and small spots are labelled;
* grey pixels form their own hue class (a white vein in red rock is rare in H too), and hue
  is rotated so red rocks do not straddle the 0/360 cut;
* surprisal uncommon values, continuous in class area, plus half the rarity of the value
  itself within its plane (the dark tail of one broad class: a crack, a pit);
* B = 0.8 % of the image diagonal, so the same outcrop gives the same points at any size;
* two peaks are one target unless the map dips below 40 % of the lower one between them,
  so three points are three targets whatever their size;
* 3/4 of the score depends on the roundness of the surroundings, which takes the long
  ledge shadows the seed papers complain about off the top;
* images above 0.13 MP are analysed at 0.13 MP (a 12 MP photo needs no flags): area
  averaging quiets sensor noise and texture before segmentation, and at B = 0.8 % of the
  diagonal nothing a point could find is lost.
"""

DEFAULT = UNCOMMON.replace(
    texture_weight=3.5,
    fused_isotropy=0.6,
    blur_fraction=0.012,
    shadow_gate=1.0,
    bands=1.0,
    frame=1.0,
    presmooth=0.7,
    layers=0.5,
    line_weight=1.0,
    wide_scale=4.0,
)
"""``uncommon`` plus texture rarity (``texture``), line rarity (``lines``: veins and cracks, not
bed contacts), the shadow gate (``shadow``), the layer discount (``layers``: a bed across the
view counts at half its rarity), a second, four times wider scale of the uncommon map
(``wide_scale``: a compact area of rare colour scores as a whole), the discounts on bands and on
patches hugging the frame (``peaks``) and a light pre-smoothing of what is segmented (sensor
noise flips small classes in and out between looks): what the rig uses unless told otherwise.
``bench.quality`` and ``bench.real`` measure it against the other profiles and the baselines."""

PROFILES: dict[str, VisionParams] = {
    "paper": PAPER,
    "uncommon": UNCOMMON,
    "default": DEFAULT,
    "field": DEFAULT,
}
"""``field`` is ``default``'s name from when texture rarity was opt-in, kept for scripts."""


def profile(name: str) -> VisionParams:
    """Look up a named profile."""
    try:
        return PROFILES[name]
    except KeyError:
        raise ValueError(f"unknown profile {name!r}; choose from {sorted(PROFILES)}") from None


def with_settings(params: VisionParams, settings: list[str]) -> VisionParams:
    """``params`` with ``NAME=VALUE`` settings applied, each value read as its field's type
    (numbers; ``true``/``false``; comma-separated tuples; ``none`` for an optional number;
    the named modes as written) and the whole validated again: how a scientist tries a choice
    the profiles leave open (``cyborgd analyze --set uncommon=surprisal``) without code.

    Examples
    --------
    >>> p = with_settings(PAPER, ["uncommon=surprisal", "blur=8", "plane_weights=1,1,2"])
    >>> p.uncommon, p.blur, p.plane_weights
    ('surprisal', 8.0, (1.0, 1.0, 2.0))
    >>> with_settings(PAPER, ["blurr=8"])
    Traceback (most recent call last):
    ...
    ValueError: unknown parameter 'blurr' (did you mean blur?)
    """
    hints = typing.get_type_hints(VisionParams)
    changes: dict[str, Any] = {}
    for item in settings:
        name, sep, text = item.partition("=")
        name, text = name.strip(), text.strip()
        if not sep or not name:
            raise ValueError(f"expected NAME=VALUE, got {item!r}")
        if name not in hints:
            near = difflib.get_close_matches(name, list(hints), n=1)
            hint = f" (did you mean {near[0]}?)" if near else ""
            raise ValueError(f"unknown parameter {name!r}{hint}")
        try:
            changes[name] = _read(hints[name], text)
        except ValueError:
            raise ValueError(f"{name}: cannot read {text!r} as {_describe(hints[name])}") from None
    return params.replace(**changes)


def _read(kind: Any, text: str) -> Any:
    """``text`` as a value of the annotated type ``kind``."""
    origin, args = typing.get_origin(kind), typing.get_args(kind)
    if origin is typing.Literal:
        if text not in args:
            raise ValueError(text)
        return text
    if origin is tuple:
        items = [t for t in text.split(",") if t.strip()]
        return tuple(_read(args[0], t.strip()) for t in items)
    if origin in (types.UnionType, typing.Union):
        if text.lower() == "none" and type(None) in args:
            return None
        return _read(next(a for a in args if a is not type(None)), text)
    if kind is bool:
        if text.lower() not in _FLAGS:
            raise ValueError(text)
        return _FLAGS[text.lower()]
    return kind(text)


_FLAGS = {"true": True, "1": True, "yes": True, "false": False, "0": False, "no": False}


def _describe(kind: Any) -> str:
    origin, args = typing.get_origin(kind), typing.get_args(kind)
    if origin is typing.Literal:
        return " | ".join(args)
    if origin is tuple:
        return f"comma-separated {args[0].__name__}s"
    if origin in (types.UnionType, typing.Union):
        return " or ".join("none" if a is type(None) else a.__name__ for a in args)
    return kind.__name__


def compared(settings: list[str]) -> dict[str, VisionParams]:
    """The three distinct profiles a benchmark compares (``field`` is ``default``'s old
    name), each with ``settings`` applied (:func:`with_settings`)."""
    return {
        name: with_settings(PROFILES[name], settings) for name in ("default", "paper", "uncommon")
    }
