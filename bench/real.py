"""Real-imagery benchmark: labelled photographs with pixel masks, methods vs baselines.

The synthetic outcrops of ``bench.quality`` are ours, so they can flatter the pipeline; here
every method looks at real images (Mars rocks, weeds on soil, road cracks, tile defects,
Curiosity navcam rocks) whose targets someone else drew. The data live outside the
repository (``shared/data/real``, see its README.md); none of it is ever copied in here.

Scoring, as the data's README states it. Each method returns its top 3 points, best first.

* hit: the point (rounded, clipped into the image) lies within 1.5 % of the image diagonal
  of a mask pixel (Euclidean distance transform of the inverted mask);
* top1: the best point hits; any3: at least one of the 3 hits; p@3: hits / 3 (a missing
  point is a miss);
* repeat@1: two more looks with Gaussian sensor noise (sigma 2 on 8-bit values, rounded and
  clipped; grey stays 1-channel), drawn from a generator seeded by crc32("set/name") so every
  method sees the same looks; the two best points must lie within 3 % of the diagonal.
  With ``--jpeg Q`` each noisy look is then saved as a JPEG at quality Q and decoded, as a
  camera delivers its frames (noise first, then the JPEG's 8-px blocks and half-resolution
  colour): the field's repeat, where two looks differ in whole blocks. The clean look, and
  so every hit rate, is the image as stored;
* chance: what a uniform random point scores, the mean dilated-mask area (top1, p@3) and
  the mean of 1 - (1 - area)^3 (any3);
* ms: median CPU milliseconds per image (the clean look, from decoded image to points), every
  method on one BLAS and one OpenCV thread as the rig's analysis processes run
  (``threads.single_thread``); CPU time, not wall time, so a shared machine's load does not
  swing the ratios (wall-time ratios moved by 25 % under load); ``speed:`` gives
  ``default``'s over RX's and colour rarity's.

Rates are per set (marsdata also per Rock-A / Rock-B tag, magnetic_tile per defect class
(MT_Blowhole, MT_Break, ...); every extra ``masks_<x>`` folder,
i.e. cwfid's weed-only masks, as an extra row ``<set>-<x>``) and pooled over all images
(every image counts once, not a mean of set means).

Methods: the ``default`` and ``paper`` profiles run exactly as they are (what they do with
image size is their business). The baselines' maps are turned into points by the pipeline's
own peak picker with blur sigma and separation = 1.5 % of the diagonal (about the hit
radius), so they are not handicapped by settings made for 216x288 scenes; the spectral
residual map keeps only its own smoothing, as in ``bench.quality``.

Usage: ``python -m bench.real [--data DIR] [--sets a,b] [--limit N] [--methods a,b]
[--jpeg Q] [--json]``.
The data folder defaults to $CYBORG_REAL_DATA, else ``shared/data/real`` beside the repo; when
it is absent the benchmark says so in one line and exits 0.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import sys
import time
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bench.baselines import (
    colour_rarity,
    points_from_map,
    random_points,
    rx_anomaly,
    spectral_residual,
)
from bench.real_score import (
    HIT_SHARE,
    REPEAT_SHARE,
    TOP_N,
    diagonal,
    hits,
    looks,
    near_mask,
    score,
)
from bench.stats import repeats, wilson
from cyborg.daemon.sim.camera_effects import jpeg_quality
from cyborg.daemon.vision.imageio import ImageError, as_bgr8, read_image
from cyborg.daemon.vision.interest import InterestPoint
from cyborg.daemon.vision.job import analyze_image, input_points
from cyborg.daemon.vision.params import VisionParams, compared
from cyborg.daemon.vision.threads import single_thread
from cyborg.protocol.settings import add_settings_argument

SET_ORDER = ("marsdata", "cwfid", "crackforest", "magnetic_tile", "ai4mars")
TAG_SETS = frozenset({"marsdata", "magnetic_tile"})
"""Sets also reported per manifest tag: marsdata's rock kinds, magnetic tiles' defect classes
(the others' tags are provenance, not subsets)."""
BASELINES = ("spectral-residual", "colour-rarity", "rx-anomaly", "random")
RATES = ("top1", "any3", "p3", "repeat1", "ms")
GOAL_MARGIN, GOAL_SET_DEFICIT, GOAL_REPEAT = 0.10, 0.05, 0.90

Method = Callable[[np.ndarray, np.random.Generator], list[InterestPoint]]


def default_data_dir() -> Path:
    """$CYBORG_REAL_DATA, else ``shared/data/real`` next to the repository."""
    env = os.environ.get("CYBORG_REAL_DATA")
    return Path(env) if env else Path(__file__).resolve().parents[2] / "shared/data/real"


def pipeline_method(params: VisionParams) -> Method:
    """A profile run as it is; points brought back to input pixels if it ever reduced."""

    def method(image: np.ndarray, _rng: np.random.Generator) -> list[InterestPoint]:
        bgr, res = analyze_image(image, params)
        return input_points(bgr.shape, res)

    return method


def methods(settings: Sequence[str] = ()) -> dict[str, Method]:
    """Every method in the run, pipeline profiles first; ``settings`` (``NAME=VALUE``,
    ``params.with_settings``) change each pipeline profile alike, the baselines not at all."""

    def from_map(saliency: Callable[[np.ndarray], np.ndarray], blur: bool) -> Method:
        return lambda img, _r: points_from_map(saliency(img), blur)

    return {
        **{name: pipeline_method(p) for name, p in compared(list(settings)).items()},
        "spectral-residual": from_map(lambda img: spectral_residual(as_bgr8(img)), False),
        "colour-rarity": from_map(colour_rarity, True),
        "rx-anomaly": from_map(lambda img: rx_anomaly(as_bgr8(img)), True),
        "random": lambda img, rng: random_points(img.shape[:2], TOP_N, rng),
    }


@dataclass
class Record:
    """One image's outcome: hits per mask and method, repeat and time per method."""

    set: str
    name: str
    tag: str
    area: dict[str, float]
    """Dilated-mask area share per mask kind ("" = the set's main mask)."""
    flags: dict[str, dict[str, list[bool]]] = field(default_factory=dict)
    """method -> mask kind -> hit flags."""
    repeat: dict[str, bool] = field(default_factory=dict)
    ms: dict[str, float] = field(default_factory=dict)


def list_sets(data_dir: Path) -> list[str]:
    """Subfolders holding a manifest.tsv, known sets first in the README's order."""
    found = {p.parent.name for p in data_dir.glob("*/manifest.tsv")}
    return [s for s in SET_ORDER if s in found] + sorted(found - set(SET_ORDER))


def read_manifest(folder: Path) -> list[tuple[str, str]]:
    with (folder / "manifest.tsv").open(newline="") as fh:
        return [(row["name"], row.get("tag") or "") for row in csv.DictReader(fh, delimiter="\t")]


def score_image(
    folder: Path,
    name: str,
    tag: str,
    table: dict[str, Method],
    extra: list[str],
    *,
    jpeg: int | None = None,
) -> Record:
    """Run every method on one image (clean look + two noisy looks, through a JPEG at
    quality ``jpeg`` if given) and score it."""
    image = read_image(folder / "images" / name)
    masks = {"": read_image(folder / "masks" / name)}
    for kind in extra:
        masks[kind] = read_image(folder / f"masks_{kind}" / name)
    for kind, mask in masks.items():
        if mask.shape[:2] != image.shape[:2]:
            raise ImageError(f"{folder.name}/{name}: mask{kind and '_' + kind} size differs")
        if mask.ndim == 3:
            masks[kind] = mask.max(axis=2)
    near = {kind: near_mask(mask) for kind, mask in masks.items()}
    seed = zlib.crc32(f"{folder.name}/{name}".encode())
    noisy = looks(image, seed, jpeg)
    rec = Record(folder.name, name, tag, {k: float(v.mean()) for k, v in near.items()})
    tolerance = REPEAT_SHARE * diagonal(image.shape)
    for mname, method in table.items():
        t0 = time.process_time()
        points = method(image, np.random.default_rng([seed, 0]))
        rec.ms[mname] = (time.process_time() - t0) * 1e3
        rec.flags[mname] = {kind: hits(n, points) for kind, n in near.items()}
        again = [method(look, np.random.default_rng([seed, 1 + k])) for k, look in enumerate(noisy)]
        rec.repeat[mname] = repeats(*again, tolerance)
    return rec


def summarise(records: list[Record], names: list[str], kind: str = "") -> dict[str, Any]:
    """Rates of one group of images against one mask kind, with the chance row."""
    areas = np.array([r.area[kind] for r in records])
    rates = {}
    for m in names:
        rows = [score(r.flags[m][kind]) for r in records]
        rates[m] = {k: float(np.mean([row[k] for row in rows])) for k in ("top1", "any3", "p3")}
        rates[m]["repeat1"] = float(np.mean([r.repeat[m] for r in records]))
        rates[m]["ms"] = float(np.median([r.ms[m] for r in records]))
    chance = {
        "top1": float(areas.mean()),
        "any3": float(np.mean(1.0 - (1.0 - areas) ** 3)),
        "p3": float(areas.mean()),
    }
    return {"n": len(records), "chance": chance, "rates": rates}


def run(
    data_dir: Path | str,
    sets: Sequence[str] | None = None,
    limit: int | None = None,
    methods: Sequence[str] | None = None,
    *,
    progress: bool = False,
    jpeg: int | None = None,
    settings: Sequence[str] = (),
) -> dict[str, Any]:
    """Score the chosen methods on the chosen sets; returns per-group and pooled rates.
    ``jpeg``: the repeat looks go through a JPEG at this quality (1..100); ``settings``
    change the pipeline profiles (``methods``).

    Groups, in order: each set, then its tag subsets (``marsdata/Rock-A``) and extra masks
    (``cwfid-weed``); ``pooled`` last, over every image of every set against its main mask.
    Images that fail to load are listed under ``failed`` and left out.
    """
    data_dir = Path(data_dir)
    if jpeg is not None:
        jpeg_quality(jpeg)
    table = _choose(methods, settings)
    names = list(table)
    available = list_sets(data_dir)
    chosen = list(sets) if sets else available
    unknown = [s for s in chosen if s not in available]
    if unknown:
        raise ValueError(f"no such set(s) in {data_dir}: {', '.join(unknown)}")
    groups: dict[str, Any] = {}
    pooled: list[Record] = []
    failed: list[str] = []
    for set_name in chosen:
        folder = data_dir / set_name
        extra = sorted(p.name.removeprefix("masks_") for p in folder.glob("masks_*") if p.is_dir())
        entries = read_manifest(folder)[:limit]
        records = []
        for i, (name, tag) in enumerate(entries):
            if progress and i % 50 == 0:
                print(f"real: {set_name} {i}/{len(entries)}", file=sys.stderr, flush=True)
            try:
                records.append(score_image(folder, name, tag, table, extra, jpeg=jpeg))
            except ImageError as exc:
                failed.append(str(exc))
                print(f"real: skipped: {exc}", file=sys.stderr)
        if not records:
            continue
        groups[set_name] = summarise(records, names)
        if set_name in TAG_SETS:
            for tag in sorted({r.tag for r in records if r.tag}):
                subset = [r for r in records if r.tag == tag]
                groups[f"{set_name}/{tag}"] = summarise(subset, names)
        for kind in extra:
            groups[f"{set_name}-{kind}"] = summarise(records, names, kind)
        pooled += records
    if pooled:
        groups["pooled"] = summarise(pooled, names)
    return {
        "data": str(data_dir),
        "sets": [s for s in chosen if s in groups],
        "methods": names,
        "jpeg": jpeg,
        "settings": list(settings),
        "groups": groups,
        "failed": failed,
    }


def _choose(chosen: Sequence[str] | None, settings: Sequence[str] = ()) -> dict[str, Method]:
    table = methods(settings)
    if not chosen:
        return table
    unknown = [m for m in chosen if m not in table]
    if unknown:
        raise ValueError(f"unknown method(s) {', '.join(unknown)}; choose from {', '.join(table)}")
    return {m: table[m] for m in chosen}


def verdict(results: dict[str, Any]) -> dict[str, Any] | None:
    """Default vs the best baseline (per rate), against the project's goals.

    Goals: pooled top1 and any3 at least 10 points above the best baseline, no set (its main
    mask) more than 5 points below the best baseline on either, pooled repeat@1 >= 90 %.
    None when the run lacks ``default`` or every baseline.
    """
    groups = results["groups"]
    base = [m for m in results["methods"] if m in BASELINES]
    if "default" not in results["methods"] or not base or "pooled" not in groups:
        return None

    def margin(group: str, rate: str) -> tuple[float, str]:
        rates = groups[group]["rates"]
        best = max(base, key=lambda m: rates[m][rate])
        return rates["default"][rate] - rates[best][rate], best

    pooled = {rate: margin("pooled", rate) for rate in ("top1", "any3")}
    worst = min(
        ((*margin(s, rate), s, rate) for s in results["sets"] for rate in ("top1", "any3")),
        key=lambda t: t[0],
    )
    repeat = groups["pooled"]["rates"]["default"]["repeat1"]
    met = {
        "pooled_margin": all(d >= GOAL_MARGIN - 1e-9 for d, _ in pooled.values()),
        "set_deficit": worst[0] >= -GOAL_SET_DEFICIT - 1e-9,
        "repeat1": repeat >= GOAL_REPEAT,
    }
    return {
        "pooled": {rate: {"diff": d, "best_baseline": b} for rate, (d, b) in pooled.items()},
        "worst_set": {
            "diff": worst[0],
            "best_baseline": worst[1],
            "set": worst[2],
            "rate": worst[3],
        },
        "repeat1": repeat,
        "met": met,
    }


def _pct(value: float) -> str:
    return f"{100 * value:6.1f}%"


def format_table(results: dict[str, Any]) -> list[str]:
    """The readable report: one block per group with its chance row, pooled last."""
    groups = results["groups"]
    n = groups["pooled"]["n"] if "pooled" in groups else 0
    lines = [
        f"real: {n} images in {len(results['sets'])} sets from {results['data']}; hit within "
        f"{100 * HIT_SHARE:g}% of the diagonal, repeat within {100 * REPEAT_SHARE:g}%"
        + (f"; repeat looks through JPEG quality {results['jpeg']}" if results.get("jpeg") else "")
        + (f"; in every pipeline profile {' '.join(s)}" if (s := results.get("settings")) else "")
    ]
    head = ("method", "top1", "any3", "p@3", "repeat@1", "ms")
    for gname, g in groups.items():
        lines.append("")
        lines.append(f"{gname} ({g['n']} images)")
        lines.append("  {:18s} {:>7s} {:>7s} {:>7s} {:>9s} {:>8s}".format(*head))
        for m, r in g["rates"].items():
            lines.append(
                f"  {m:18s} {_pct(r['top1'])} {_pct(r['any3'])} {_pct(r['p3'])} "
                f"{_pct(r['repeat1']):>9s} {r['ms']:8.1f}"
            )
        c = g["chance"]
        lines.append(
            f"  {'chance':18s} {_pct(c['top1'])} {_pct(c['any3'])} {_pct(c['p3'])} "
            f"{'-':>9s} {'-':>8s}"
        )
    if results["failed"]:
        lines.append("")
        lines.append(f"failed to load ({len(results['failed'])}): " + "; ".join(results["failed"]))
    v = verdict(results)
    if v:
        p, w, met = v["pooled"], v["worst_set"], v["met"]

        def pts(d: float) -> str:
            return f"{100 * d:+.1f} pts"

        lo, hi = wilson(v["repeat1"], n)  # its 95 % interval over the pooled images
        lines.append("")
        lines.append(
            f"verdict: default vs best baseline, pooled top1 {pts(p['top1']['diff'])} "
            f"(vs {p['top1']['best_baseline']}), any3 {pts(p['any3']['diff'])} "
            f"(vs {p['any3']['best_baseline']}); worst set {w['set']} {w['rate']} "
            f"{pts(w['diff'])} (vs {w['best_baseline']}); pooled repeat@1 "
            f"{100 * v['repeat1']:.1f}% [{100 * lo:.0f}-{100 * hi:.0f}]. "
            "Goals: pooled margins >= +10 pts "
            f"{'met' if met['pooled_margin'] else 'NOT met'}, no set below -5 pts "
            f"{'met' if met['set_deficit'] else 'NOT met'}, repeat@1 >= 90% "
            f"{'met' if met['repeat1'] else 'NOT met'}"
        )
    speed = speed_ratios(groups["pooled"]["rates"]) if "pooled" in groups else {}
    if speed:
        lines.append(
            "speed: median CPU ms per image, default / baseline (same run, one thread): "
            + ", ".join(f"{b} {r:.2f}x (goal <= {SPEED_GOALS[b]:g})" for b, r in speed.items())
        )
    return lines


SPEED_GOALS = {"rx-anomaly": 1.5, "colour-rarity": 3.0}
"""Issue 44: ``default``'s median time per real image at most this many times the baseline's."""


def speed_ratios(rates: dict[str, dict[str, float]]) -> dict[str, float]:
    """``default``'s median ms over each baseline's of :data:`SPEED_GOALS` in the run."""
    if "default" not in rates:
        return {}
    ms = rates["default"]["ms"]
    return {b: ms / rates[b]["ms"] for b in SPEED_GOALS if b in rates and rates[b]["ms"] > 0}


def _quality(text: str) -> int:
    """argparse type of ``--jpeg``: refused before any data is looked for."""
    try:
        return jpeg_quality(int(text))
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=None, help="data folder (default: see above)")
    ap.add_argument("--sets", default="", help="comma list of sets (default: all)")
    ap.add_argument("--limit", type=int, default=None, help="first N images per set")
    ap.add_argument("--methods", default="", help="comma list of methods (default: all)")
    ap.add_argument(
        "--jpeg", type=_quality, default=None, metavar="Q", help="repeat looks through JPEG at Q"
    )
    add_settings_argument(ap, "every pipeline profile alike", default=[])
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    single_thread()  # every method is timed as the rig's analysis processes run
    try:  # a mistyped setting is refused whether or not the data is here
        methods(args.settings)
    except ValueError as exc:
        ap.error(str(exc))
    data = args.data or default_data_dir()
    if not data.is_dir() or not list_sets(data):
        print(f"real: data folder {data} is absent (no sets); nothing to score")
        return 0
    split = [s.strip() for s in args.sets.split(",") if s.strip()]
    chosen = [m.strip() for m in args.methods.split(",") if m.strip()]
    t0 = time.perf_counter()
    try:
        results = run(
            data,
            split or None,
            args.limit,
            chosen or None,
            progress=True,
            jpeg=args.jpeg,
            settings=args.settings,
        )
    except ValueError as exc:
        ap.error(str(exc))
    results["wall_s"] = round(time.perf_counter() - t0, 1)
    if args.json:
        print(json.dumps({**results, "verdict": verdict(results)}, indent=2))
        return 0
    print("\n".join(format_table(results)))
    print(f"wall time {results['wall_s']:.1f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
