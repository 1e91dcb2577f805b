"""Target-or-background benchmark: what "no further target" hides, and what it must not.

The pipeline marks a point ``target=False`` when its score cannot be told from the view's
background (``peaks.mark_background``: a height over the interest map's median of at most
``spreads`` robust standard deviations of the map, or under ``share`` of the best point's
height). A real target must never be hidden; noise should be. Every profile looks at:

* the generated regimes of ``bench.quality`` (``tiny``, ``seed``, ``large``, ``veins`` with
  planted targets; ``empty`` with none), hit as there (within the scaled tolerance of a
  target's pixels);
* ``strip``: 1 x 5000 and 5000 x 1 images (a row and a column of an ``empty`` scene
  stretched), where nothing is a target;
* the real labelled images of ``bench.real`` (``shared/data/real``), hit as there (within
  1.5 % of the diagonal of a mask pixel); each connected part of the dilated mask is a
  target.

Figures per group: points, hits, hits marked, **lost** (targets hit by a marked point and by
no unmarked one: hidden targets, the figure that must be 0), misses, misses marked, and the
hit rate of the marked points against chance (the share of the view within hit distance
of a target): marked points that hit no more often than a random point are noise.
``height`` and ``share`` give the lowest height (in robust deviations) and the lowest share
of the best point's height of any hit: the margins the constants leave.

Measured (seeds 0..39, all 347 real images; ``python -m bench.targets --scenes 40 --sweep``),
with the constants ``peaks.SPREADS`` = 0.25 and ``peaks.SHARE`` = 0.025: of 4933 points
(1705 hits) over the three profiles, **no hit marked, no target lost**; marked: default 271
of 1175 misses (all 240 strip points, 31 of the rest), paper 2 of 755, uncommon 5 of 1298.
The hits closest to the line: default 0.38 deviations and 3.1 % of the best (the grey wet
patch of ``large`` 14, which default barely sees), 4.2 % (a Mars rock); paper 0.75
deviations (a crack inside a rare bed, ``veins`` 29). Hence the constants: the sweep's
(0.5, 0.03) loses that wet patch and (1, 0.05) three targets (2 + 1), for 11 and 96 more
misses marked. The noise the rule is for sits well inside: the demo's 60 m points #2 and
#3 at 0.4-1.4 % of #1, and every strip point (score 0, the frame discounts it all).

Usage: ``python -m bench.targets [--scenes 40] [--seed 0] [--profiles default,paper,uncommon]
[--data DIR] [--limit N] [--spreads 0.25] [--share 0.025] [--sweep] [--json]``.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from bench.quality_score import Truth, scaled_tolerance, truth
from bench.real import default_data_dir, list_sets, read_manifest
from bench.real_score import near_mask
from cyborg.daemon.sim.regimes import REGIMES
from cyborg.daemon.vision.imageio import ImageError, read_image
from cyborg.daemon.vision.interest import InterestMap, InterestPoint
from cyborg.daemon.vision.job import analyze_image, input_points
from cyborg.daemon.vision.params import PROFILES
from cyborg.daemon.vision.peaks import SHARE, SPREADS, background, mark_background

PROFILE_NAMES = ("default", "paper", "uncommon")
STRIP = 5000
"""The long side of the strips: in a 1 x 5000 image every patch hugs the frame."""
SWEEP = ((0.0, 0.0), (0.0, 0.025), (0.25, 0.025), (0.25, 0.03), (0.5, 0.03), (1.0, 0.05))
"""(spreads, share) pairs ``--sweep`` compares."""
COUNTS = ("points", "hits", "hits_marked", "lost", "misses", "misses_marked", "marked")


@dataclass(frozen=True)
class View:
    """One analysed image: its interest map, its points and which target each one hit."""

    group: str
    interest: InterestMap
    points: list[InterestPoint]
    owners: list[int | None]
    """The target each point hit, None for a miss."""
    chance: float
    """The share of the image within hit distance of a target."""


def analysed(
    group: str,
    image: np.ndarray,
    profile: str,
    owner: Callable[[int, int], int | None],
    chance: float = 0.0,
) -> View:
    """``image`` through ``profile`` as the rig runs it; ``owner(x, y)`` names the target a
    point at input pixel (x, y) hits, or None."""
    bgr, res = analyze_image(image, PROFILES[profile])
    points = input_points(bgr.shape, res)
    rows, cols = bgr.shape[:2]
    owners = [
        owner(min(cols - 1, max(0, round(p.x))), min(rows - 1, max(0, round(p.y)))) for p in points
    ]
    return View(group, res.interest, points, owners, chance)


def generated(profile: str, n_scenes: int, seed: int) -> Iterator[View]:
    """The quality regimes' scenes, then strips stretched from the ``empty`` scenes."""
    for name, generate in REGIMES.items():
        for i in range(n_scenes):
            scene = generate(seed + i)
            gt = truth(scene, scaled_tolerance(scene.image.shape[:2], 6.0))

            def owner(x: int, y: int, gt: Truth = gt) -> int | None:
                return gt.owner(y, x, True) if gt.near_target[y, x] else None

            yield analysed(name, scene.image, profile, owner, float(gt.near_target.mean()))
    for i in range(n_scenes):
        image = REGIMES["empty"](seed + i).image
        rows, cols = image.shape[:2]
        row = cv2.resize(
            image[rows // 2 : rows // 2 + 1], (STRIP, 1), interpolation=cv2.INTER_LINEAR
        )
        col = cv2.resize(
            image[:, cols // 2 : cols // 2 + 1], (1, STRIP), interpolation=cv2.INTER_LINEAR
        )
        for strip in (row, col):
            yield analysed("strip", strip, profile, lambda _x, _y: None)


def real(profile: str, data: Path, limit: int | None) -> Iterator[View]:
    """The labelled real images, each connected part of its dilated mask a target."""
    for set_name in list_sets(data):
        folder = data / set_name
        for name, _tag in read_manifest(folder)[:limit]:
            try:
                image = read_image(folder / "images" / name)
                mask = read_image(folder / "masks" / name)
            except ImageError as exc:
                print(f"targets: skipped: {exc}", file=sys.stderr)
                continue
            near = near_mask(mask.max(axis=2) if mask.ndim == 3 else mask)
            _, parts = cv2.connectedComponents(near.astype(np.uint8), None, 8)

            def owner(x: int, y: int, parts: np.ndarray = parts) -> int | None:
                return int(parts[y, x]) or None

            yield analysed(f"real/{set_name}", image, profile, owner, float(near.mean()))


def tally(views: Sequence[View], spreads: float, share: float) -> dict[str, dict[str, float]]:
    """Counts per group, then ``all``, with the rule at (``spreads``, ``share``)."""
    out: dict[str, dict[str, float]] = {}
    for view in views:
        marks = mark_background(view.interest, view.points, spreads=spreads, share=share)
        typical, spread = background(view.interest.grid)
        best = max((p.score for p in view.points), default=0.0) - typical
        hidden = {
            o for o, p in zip(view.owners, marks, strict=True) if o is not None and not p.target
        }
        shown = {o for o, p in zip(view.owners, marks, strict=True) if o is not None and p.target}
        for group in (view.group, "all"):
            row = out.setdefault(
                group,
                dict.fromkeys((*COUNTS, "chance"), 0.0) | {"height": np.inf, "share": np.inf},
            )
            row["lost"] += len(hidden - shown)
            for owner, p in zip(view.owners, marks, strict=True):
                row["points"] += 1
                row["marked"] += not p.target
                if owner is None:
                    row["misses"] += 1
                    row["misses_marked"] += not p.target
                    continue
                row["hits"] += 1
                row["hits_marked"] += not p.target
                height = p.score - typical
                row["height"] = min(row["height"], height / spread if spread > 0 else np.inf)
                row["share"] = min(row["share"], height / best if best > 0 else np.inf)
            row["chance"] += view.chance * sum(not p.target for p in marks)
    if "all" in out:
        out["all"] = out.pop("all")  # last
    return out


def _line(group: str, row: dict[str, float]) -> str:
    marked = row["marked"]
    rate = (
        f"{100 * row['hits_marked'] / marked:5.1f}% vs {100 * row['chance'] / marked:5.1f}%"
        if marked
        else f"{'-':>16s}"
    )
    figures = "".join(f"{int(row[k]):>8d}" for k in COUNTS[:-1])
    return f"  {group:22s}{figures}  {rate}  {row['height']:6.2f} {row['share']:6.3f}"


def report(results: dict[str, dict[str, dict[str, float]]], spreads: float, share: float) -> None:
    """One block per profile."""
    print(f"rule: marked when height <= {spreads:g} robust deviations or < {share:g} x the best's")
    head = "".join(f"{k:>8s}" for k in ("points", "hits", "hitmark", "LOST", "misses", "missmrk"))
    for profile, table in results.items():
        print(f"\n{profile}\n  {'group':22s}{head}  marked hit vs chance  height  share")
        for group, row in table.items():
            print(_line(group, row))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=int, default=40, help="generated scenes per regime")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--profiles", default=",".join(PROFILE_NAMES), help="comma list")
    ap.add_argument("--data", type=Path, default=None, help="real data folder (see bench.real)")
    ap.add_argument("--limit", type=int, default=None, help="first N real images per set (0: none)")
    ap.add_argument("--spreads", type=float, default=SPREADS, help="robust deviations of the map")
    ap.add_argument("--share", type=float, default=SHARE, help="share of the best point's height")
    ap.add_argument("--sweep", action="store_true", help="also the totals at other constants")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    profiles = [p.strip() for p in args.profiles.split(",") if p.strip()]
    unknown = [p for p in profiles if p not in PROFILES]
    if unknown:
        ap.error(f"unknown profile(s) {', '.join(unknown)}; known: {', '.join(PROFILES)}")
    data = args.data or default_data_dir()
    has_data = data.is_dir() and bool(list_sets(data)) and args.limit != 0
    views: dict[str, list[View]] = {}
    for profile in profiles:
        views[profile] = list(generated(profile, args.scenes, args.seed))
        if has_data:
            views[profile] += real(profile, data, args.limit)
    results = {p: tally(v, args.spreads, args.share) for p, v in views.items()}
    sweep = (
        {f"{s:g},{f:g}": {p: tally(v, s, f)["all"] for p, v in views.items()} for s, f in SWEEP}
        if args.sweep
        else {}
    )
    if args.json:
        print(json.dumps({"results": results, "sweep": sweep}, indent=2, default=float))
        return 0
    last = args.seed + args.scenes - 1
    print(
        f"targets: {args.scenes} generated scenes per regime (seeds {args.seed}..{last}), "
        + (f"real images from {data}" if has_data else "no real images")
    )
    report(results, args.spreads, args.share)
    if sweep:
        print("\nsweep (all groups): spreads,share -> hits marked / LOST / misses marked of points")
        for key, per in sweep.items():
            cells = "; ".join(
                f"{p} "
                + "/".join(str(int(r[k])) for k in ("hits_marked", "lost", "misses_marked"))
                + f" of {int(r['points'])}"
                for p, r in per.items()
            )
            print(f"  {key:9s} {cells}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
