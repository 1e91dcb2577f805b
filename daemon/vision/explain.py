"""Why a point is interesting: the numbers per plane, and one line a geologist can read.

The numeric explanation is exact: each plane's share of the point's score is the
Gaussian-weighted mean of its weighted uncommon map around the point (what the blur
summed), with the class that gave most of it. The plain line compares what lies inside
the point's radius with the whole image: its colour in words, how much darker or brighter
it is than the rest, and its share of the area, e.g. "dark grey patch, darker than 97 % of
the image; 0.4 % of the area" or "green patch on brown rock; 2.1 % of the area".
"""

from __future__ import annotations

import math

import numpy as np

from .cooccurrence import Segmentation
from .hsi import HSIPlanes
from .interest import InterestMap, InterestPoint
from .kernels import kernel
from .params import VisionParams
from .uncommon import uncommon_map

__all__ = [
    "PLANE_NAMES",
    "clauses",
    "colour_name",
    "describe",
    "explain_points",
    "percent",
    "plain_lines",
]

PLANE_NAMES = ("H", "S", "I")

# Hue sectors in degrees (upper bounds) and their names; saturation and intensity refine.
_HUES = ((15, "red"), (40, "orange"), (70, "yellow"), (165, "green"), (200, "cyan"),
         (260, "blue"), (290, "purple"), (340, "pink"), (360, "red"))  # fmt: skip


def colour_name(hue_deg: float, saturation: float, intensity: float) -> str:
    """A plain colour word for a geometric HSI colour (S and I on 0..255).

    Examples
    --------
    >>> colour_name(120, 150, 100), colour_name(25, 60, 70), colour_name(0, 5, 240)
    ('green', 'brown', 'white')
    >>> colour_name(0, 5, 40), colour_name(210, 8, 128), colour_name(10, 120, 120)
    ('black', 'grey', 'red')
    """
    if saturation < 20:
        if intensity >= 200:
            return "white"
        return "black" if intensity < 50 else "grey"
    name = next(n for top, n in _HUES if hue_deg % 360 < top)
    if name in ("orange", "red", "yellow") and intensity < 110 and saturation < 140:
        return "brown"
    if name == "yellow" and saturation < 60:
        return "buff"
    return name


_ROCK = frozenset({"red", "orange", "yellow", "brown", "buff", "grey", "black", "white"})
"""The colours a view of rock shows as a whole; another (green, blue, purple) is a plant, the
sky or a painted object filling the view, not rock."""


def percent(share: float) -> str:
    """A share (0..1) in percent as a reader takes it: never "100" unless it is all, never
    "0" unless it is none, two significant digits below 10.

    >>> [percent(s) for s in (0.0, 1e-5, 0.00079, 0.042, 0.5, 0.995, 0.9999, 1.0)]
    ['0', '0.001', '0.079', '4.2', '50', '99.5', '99.99', '100']
    """
    pct = 100.0 * share
    if pct <= 0.0 or pct >= 100.0:
        return f"{min(max(pct, 0.0), 100.0):.0f}"
    if pct < 10.0:
        return f"{max(float(f'{pct:.2g}'), 0.001):g}"
    digits = 0
    while digits < 4 and round(pct, digits) >= 100.0:
        digits += 1
    return f"{math.floor(pct * 10**digits) / 10**digits:.{digits}f}" if digits else f"{pct:.0f}"


_ANGLES = np.arange(256) * (2 * math.pi / 256.0)
_SAMPLE = 1 << 18
"""Pixels enough to describe a whole image's colour and tones."""


def _middle(counts: np.ndarray) -> float:
    """The median code of the values these 256 counts are of (the upper middle one)."""
    return float(np.searchsorted(np.cumsum(counts), (int(counts.sum()) + 1) / 2))


@kernel
def _histograms(h: np.ndarray, s: np.ndarray, i: np.ndarray) -> tuple:
    """In one pass over the pixels, in order: each hue code's summed saturation (+ 1e-9 a
    pixel; float64, ``np.bincount``'s sums bit for bit) and the counts of the S and of the I
    codes (256 each)."""
    weight = np.zeros(256)
    count_s = np.zeros(256, np.int64)
    count_i = np.zeros(256, np.int64)
    for k in range(len(h)):
        weight[h[k]] += np.float64(s[k]) + 1e-9
        count_s[s[k]] += 1
        count_i[i[k]] += 1
    return weight, count_s, count_i


def _typical(h: np.ndarray, s: np.ndarray, i: np.ndarray) -> tuple[str, np.ndarray]:
    """The colour word of a region's pixels: saturation-weighted mean hue, median S and I
    (by histograms: cheap on a whole photograph); and the counts of its I codes."""
    if h.size == 0:
        return "grey", np.zeros(256, np.int64)
    weight, count_s, count_i = _histograms(h.ravel(), s.ravel(), i.ravel())
    mean = math.atan2(float(weight @ np.sin(_ANGLES)), float(weight @ np.cos(_ANGLES)))
    return colour_name(math.degrees(mean) % 360, _middle(count_s), _middle(count_i)), count_i


_CORE = 0.5
"""The share of a point's radius whose pixels give its colour and tone."""


def plain_lines(points: list[InterestPoint], hsi: HSIPlanes) -> list[str]:
    """One sentence per point on what it found, comparing its patch with the whole image.

    Examples
    --------
    >>> from cyborg.daemon.vision.hsi import rgb_to_hsi
    >>> img = np.full((100, 100, 3), (60, 100, 140), np.uint8)    # brown rock (BGR)
    >>> img[40:50, 40:50] = (40, 150, 110)                         # a green plant
    >>> img[80:90, 10:20] = (30, 50, 70)                           # a wet stain
    >>> pts = [InterestPoint(1, 44.5, 44.5, 1.0, 5.0), InterestPoint(2, 14.5, 84.5, 1.0, 5.0)]
    >>> for line in plain_lines(pts, rgb_to_hsi(img)):
    ...     print(line)
    green patch on brown rock; 0.8 % of the area
    dark brown patch, darker than 99 % of the image; 0.8 % of the area
    >>> leaf = np.full((100, 100, 3), (40, 150, 110), np.uint8)   # a plant fills the view
    >>> leaf[40:50, 40:50] = (60, 100, 140)
    >>> plain_lines(pts[:1], rgb_to_hsi(leaf))
    ['brown patch in a mostly green view; 0.8 % of the area']
    >>> import cv2
    >>> rust = cv2.circle(img.copy(), (50, 50), 3, (35, 40, 185), -1)  # a red spot seen
    >>> [plain_lines([InterestPoint(1, 50.0, 50.0, 1.0, r)], rgb_to_hsi(rust))[0].split(";")[0]
    ...  for r in (3.0, 6.0)]                                  # close and from afar
    ['dark red patch on brown rock', 'dark red patch on brown rock']
    """
    rows, cols = hsi.i.shape
    step = max(1, math.isqrt(rows * cols // _SAMPLE))  # the whole image's colour and tones
    h, sat, i = (plane[::step, ::step] for plane in hsi.planes)  # from a lattice of pixels
    whole, tones = _typical(h, sat, i)
    below = np.concatenate([[0], np.cumsum(tones)])
    lines = []
    for point in points:
        radius = max(point.radius, 1.0)
        r0, r1 = max(0, math.floor(point.y - radius)), min(rows, math.ceil(point.y + radius) + 1)
        c0, c1 = max(0, math.floor(point.x - radius)), min(cols, math.ceil(point.x + radius) + 1)
        yy, xx = np.ogrid[r0:r1, c0:c1]
        dist2 = (yy - point.y) ** 2 + (xx - point.x) ** 2
        inside = dist2 <= radius**2
        if not inside.any():
            inside = np.ones((r1 - r0, c1 - c0), bool)
        # Its colour and tone are its core's: the blurred patch is up to twice the target's
        # size, and a red spot's disc on orange rock would read orange from afar, red close.
        core = dist2 <= max(_CORE * radius, 1.5) ** 2
        h, sat, i = (plane[r0:r1, c0:c1][core if core.any() else inside] for plane in hsi.planes)
        here, tones = _typical(h, sat, i)
        level = _middle(tones)
        darker = 1.0 - below[int(level) + 1] / below[-1]  # share strictly brighter
        brighter = below[int(level)] / below[-1]  # share strictly darker
        area = 100.0 * inside.sum() / (rows * cols)  # what the patch covers of this view
        kind = "patch" if area >= 0.2 else "spot"
        tone, versus = "", ""
        if darker >= 0.8:
            tone, versus = "dark ", f", darker than {percent(darker)} % of the image"
        elif brighter >= 0.8:
            tone, versus = "bright ", f", brighter than {percent(brighter)} % of the image"
        if here != whole:
            # Only a rock colour is called rock: at 10 m a plant can fill the view.
            ground = f"on {whole} rock" if whole in _ROCK else f"in a mostly {whole} view"
            head = f"{tone}{here} {kind} {ground}"
        elif tone:
            head = f"{tone}{here} {kind}{versus}"
        else:
            head = f"{here} {kind} of unusual tone or texture"
        lines.append(f"{head}; {percent(area / 100)} % of the area")
    return lines


def explain_points(
    points: list[InterestPoint],
    segs: tuple[Segmentation, ...],
    params: VisionParams,
    maps: list[np.ndarray] | None = None,
    *,
    texture: np.ndarray | None = None,
    shade: np.ndarray | None = None,
    layers: list[np.ndarray] | None = None,
    bars: np.ndarray | None = None,
    interest: InterestMap | None = None,
) -> list[list[dict]]:
    """Say, for each point, which planes and classes made it interesting.

    For each plane: its share of the score (the Gaussian-weighted mean of its weighted
    uncommon map around the point, which is exactly what the blur summed) and the class that
    contributed most there (rank k of K, its value, its share of the image and its mean
    uncommon value there). ``maps`` are the planes' uncommon maps, when the caller has them.
    With ``texture`` (``texture.texture_rarity``, fused in with ``texture_weight``) a last
    entry gives the texture rarity around the point (squared robust standard deviations,
    weighted as the fusion blurred it) and the share of the image whose texture is commoner.
    With ``shade`` (``shadow.shadow_likelihood``) an entry gives the point's shadow
    likelihood, weighted as the blur summed: a point the gate could not take off the top
    says how likely it is shade. With ``layers`` (each plane's ``layers.layer_share``) an
    entry gives how much the point lies on a layer across the view: each plane's share,
    weighted likewise, averaged over the planes by their contributions (the classes that
    made the point rare were discounted by that much, ``VisionParams.layers``). With ``bars``
    (``lines.line_rarity``, signed) and the ``interest`` map they went into, an entry gives the
    strongest bar within the point's window, in robust standard deviations of the image's bar
    contrast (+ bright, - dark), what the line term added at the point before its weight, in
    the interest's units (0 at the image's median, 1 at its 99.5th percentile or at
    ``interest._NO_LINE``), and its share of the point's score.
    """
    if not points:
        return []
    rows, cols = segs[0].labels.shape
    sigma = params.sigma((rows, cols))
    if maps is None:
        maps = [uncommon_map(seg, params) for seg in segs]
    step = max(1, math.isqrt(rows * cols // _SAMPLE))
    sample = None if texture is None else texture[::step, ::step]
    out = []
    for point in points:
        box, kernel = _gaussian_window(point, sigma, (rows, cols))
        planes = []
        for name, seg, umap, weight in zip(
            PLANE_NAMES, segs, maps, params.plane_weights, strict=True
        ):
            window = seg.labels[box]
            scored = umap[box] * kernel
            by_class = np.bincount(window.ravel(), weights=scored.ravel(), minlength=seg.k + 1)
            entry: dict = {"plane": name, "contribution": round(float(scored.sum()) * weight, 3)}
            entry["classes"] = seg.k
            if seg.k and by_class[1:].max() > 0:
                k = int(np.argmax(by_class[1:])) + 1
                cls = seg.classes[k - 1]
                grey = name == "H" and params.hue_grey == "class" and cls.span[0] == 0
                value = "grey" if grey else _natural_value(name, seg.original_value(cls.center))
                weight_k = max(float(kernel[window == k].sum()), 1e-12)
                entry.update(
                    {
                        "class": k,
                        "value": value,
                        "area_fraction": round(cls.area / (rows * cols), 5),
                        "uncommon": round(float(by_class[k]) / weight_k, 3),
                    }
                )
            planes.append(entry)
        if texture is not None and params.texture_weight > 0:
            planes.append(_texture_entry(texture, point, sigma * params.texture_blur, sample))
        if shade is not None:
            likelihood = float((shade[box] * kernel).sum())
            planes.append({"plane": "shade", "likelihood": round(likelihood, 3)})
        if layers is not None:
            # Each plane's layer share around the point, weighted by what that plane gave:
            # a stain on a bed shares the bed's hue class, not the class that made it rare.
            weights = [e["contribution"] for e in planes[:3]]
            shares = [float((plane[box] * kernel).sum()) for plane in layers]
            share = float(np.dot(weights, shares)) / sum(weights) if sum(weights) > 0 else 0.0
            planes.append({"plane": "layer", "share": round(share, 3)})
        added = None if interest is None else interest.lines
        if bars is not None and added is not None:
            window = bars[box]
            strongest = float(window.ravel()[np.argmax(np.abs(window))])
            f = interest.factor
            cell = (
                min(int(point.y) // f, added.shape[0] - 1),
                min(int(point.x) // f, added.shape[1] - 1),
            )
            units = float(added[cell]) / params.line_weight
            share = float(added[cell]) / point.score if point.score > 0 else 0.0
            planes.append(
                {
                    "plane": "line",
                    "contrast": round(strongest, 2),
                    "units": round(units, 3),
                    "share": round(share, 3),
                }
            )
        out.append(planes)
    return out


def _gaussian_window(
    point: InterestPoint, sigma: float, shape: tuple[int, ...]
) -> tuple[tuple[slice, slice], np.ndarray]:
    """The pixels within 2.5 sigma of ``point`` and their Gaussian weights (summing to 1):
    what the interest blur summed around it."""
    rad = max(1, math.ceil(2.5 * sigma))
    x, y = round(point.x), round(point.y)
    r0, r1 = max(0, y - rad), min(shape[0], y + rad + 1)
    c0, c1 = max(0, x - rad), min(shape[1], x + rad + 1)
    yy, xx = np.mgrid[r0:r1, c0:c1]
    kernel = np.exp(-((yy - point.y) ** 2 + (xx - point.x) ** 2) / (2.0 * sigma**2))
    return (slice(r0, r1), slice(c0, c1)), kernel / kernel.sum()


def _texture_entry(
    texture: np.ndarray, point: InterestPoint, sigma: float, sample: np.ndarray
) -> dict:
    """The texture rarity around ``point`` (Gaussian-weighted, sigma) and its rank among
    the image's pixels (``sample``: the rarity on a lattice of them), counted: a few points
    need a few passes, where sorting the sample took more than them all."""
    box, kernel = _gaussian_window(point, sigma, texture.shape)
    rarity = float((texture[box] * kernel).sum())
    # Compared in float64, as a search in the sorted sample compares them.
    commoner = np.count_nonzero(sample < np.float64(rarity)) / max(sample.size, 1)
    return {"plane": "texture", "rarity": round(rarity, 3), "rarer_than": round(commoner, 4)}


def clauses(explanation: list[dict]) -> str:
    """The plain-language words on texture, shade, layers, thin lines and the aim for a point's
    line ("" for none).

    Examples
    --------
    >>> clauses([{"plane": "texture", "rarity": 31.0, "rarer_than": 0.987}])
    '; texture rarer than 99 % of the image'
    >>> clauses([{"plane": "I", "contribution": 3.0}, {"plane": "shade", "likelihood": 0.7}])
    '; probably in shade'
    >>> clauses([{"plane": "layer", "share": 0.8}])
    '; part of a layer across the view'
    >>> line = {"plane": "line", "contrast": -14.0, "units": 0.9, "share": 0.4}
    >>> clauses([line])
    '; a thin dark line'
    >>> clauses([{"plane": "shade", "likelihood": 0.9}, line])
    '; probably in shade'
    >>> clauses([dict(line, share=0.1)])          # a line nearby, not what made the point
    ''
    >>> clauses([{"plane": "aim", "kind": "vegetation", "match": "set aside"}])
    '; set aside by the aim (vegetation)'
    """
    words = ""
    # A dark line in shade is the shadow's own rim or end, not a crack: shade says it.
    shaded = any(e["plane"] == "shade" and e["likelihood"] >= _SHADE for e in explanation)
    for e in explanation:
        if e["plane"] == "texture" and e["rarer_than"] >= _RARE_TEXTURE:
            words += f"; texture rarer than {percent(e['rarer_than'])} % of the image"
        elif e["plane"] == "shade" and e["likelihood"] >= _SHADE:
            words += "; probably in shade"
        elif e["plane"] == "layer" and e["share"] >= _LAYER:
            words += "; part of a layer across the view"
        elif e["plane"] == "line" and not shaded and _made_by_line(e):
            words += f"; a thin {'bright' if e['contrast'] > 0 else 'dark'} line"
        elif e["plane"] == "aim" and e["match"] != "other":
            words += _AIM_WORDS[e["match"]].format(kind=e["kind"])
    return words


_AIM_WORDS = {"sought": "; what the aim seeks", "set aside": "; set aside by the aim ({kind})"}
"""What a point's line says of the aim (``aims.aim_entry``); a point of another kind, nothing."""
_RARE_TEXTURE = 0.9
"""A point's surroundings count as of rare texture when 9 in 10 of the image's pixels have
commoner texture."""
_SHADE = 0.5
"""A point whose surroundings are more likely shade than not is said to be in shade."""
_LAYER = 0.5
"""A point whose surroundings are more layer than not is said to be part of one."""
_LINE_UNITS = 0.5
"""A point is said to be on a thin line when the line term gave it at least half a unit of
interest: grain and laminae make bars of 15-25 robust standard deviations in one pixel in a
thousand of a view with nothing in it, so the strongest bar near a point says little alone,
and such a view's line rarity never reaches half a unit (``interest._NO_LINE``)."""


def _made_by_line(entry: dict) -> bool:
    """The line term gave the point half a unit or more, and a fifth of its score or more."""
    return entry["units"] >= _LINE_UNITS and entry["share"] >= _LINE_SHARE


_LINE_SHARE = 0.2
"""...and when that is at least a fifth of its score: a spot beside a bed's pale rim has a
line near it without being one."""


def _natural_value(plane: str, value: int) -> float:
    """Hue in degrees; S and I stay 0..255."""
    return round(value * 360.0 / 256.0, 1) if plane == "H" else float(value)


def describe(explanation: list[dict]) -> str:
    """The numeric explanation in one line, strongest plane first."""
    parts = []
    for e in sorted(explanation, key=lambda e: -e.get("contribution", 0.0)):
        if "class" not in e:
            continue
        value = e["value"] if isinstance(e["value"], str) else f"{e['value']:g}"
        unit = "deg" if e["plane"] == "H" and not isinstance(e["value"], str) else ""
        parts.append(
            f"{e['plane']} class {e['class']}/{e['classes']} ({value}{unit}, "
            f"{percent(e['area_fraction'])}% of image) +{e['contribution']:.1f}"
        )
    summary = "; ".join(parts) if parts else "no segmented class nearby"
    texture = [e for e in explanation if e["plane"] == "texture"]
    if texture:
        rarity, share = texture[0]["rarity"], percent(texture[0]["rarer_than"])
        summary += f"; texture rarity {rarity:.3g} (rarer than {share}% of image)"
    line = [e for e in explanation if e["plane"] == "line"]
    if line:
        summary += f"; bar {line[0]['contrast']:+.3g} robust sd, line {line[0]['units']:.2f} unit"
    return summary
