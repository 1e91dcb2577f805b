"""Novelty benchmark: how many points the rig calls "new" on seeded simulated walks.

Each walk runs the survey engine in-process as ``bench.approach`` does, on
``sim://world?seed=N`` (or, with ``--scene outcrop``, the demo's ``sim://outcrop``, whose
targets include green plants): the 300 m station, the same view surveyed again (no choice between:
same place, same pointing), then 60 m and 10 m, each aimed at the station before's #1. Every
point's explanation ends with its memory clause; the figures count the clauses per station:
``new`` ("new since ..."), ``ranked`` ("#k at ..."), ``seen`` ("seen at ...").

Nothing new can appear in the repeat; the 60 m #1 is the 300 m target looked at closer.

Usage: ``python -m bench.novelty [--walks 3] [--seed 1000] [--scene world|outcrop] [--json]``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import re
import tempfile
import time
from collections import Counter
from pathlib import Path

from cyborg.daemon.archive import Archive
from cyborg.daemon.camera import open_camera
from cyborg.daemon.config import SurveyConfig
from cyborg.daemon.ptu import open_ptu
from cyborg.daemon.rig import Rig
from cyborg.daemon.survey import Survey
from cyborg.daemon.worker import VisionWorker
from cyborg.protocol.messages import ChooseTarget, InterestResult, SurveyStart

from .approach import HEIGHT, HFOV, WIDTH, _quiet

STATIONS = ("300 m", "300 m again", "60 m", "10 m")


def clause(why: str) -> str:
    """The memory clause a point's explanation ends with, by kind."""
    last = why.rsplit("; ", 1)[-1]
    if last.startswith("new since "):
        return "new"
    if re.match(r"#\d+ at ", last):
        return "ranked"
    return "seen" if last.startswith("seen at ") else "none"


async def walk(seed: int, scene: str, work: Path) -> list[InterestResult]:
    """The four stations' results on ``scene`` (world, outcrop) of ``seed``."""
    ptu = open_ptu("emu://?time_scale=200")
    url = f"sim://{scene}?seed={seed}&width={WIDTH}&height={HEIGHT}&hfov={HFOV}"
    rig = Rig(ptu, lambda pose: open_camera(url, pose=pose))
    archive = Archive(work / str(seed), "bench")
    archive.open()
    results = []
    async with VisionWorker() as worker:
        await ptu.open()
        survey = Survey(
            rig, worker, archive, SurveyConfig(simulate_approach=True), hfov=HFOV,
            telemetry=_quiet(),
        )  # fmt: skip
        try:
            for k in range(len(STATIONS)):
                survey.start(SurveyStart(), "bench")
                await survey._task
                result = survey._result
                if result is None or not result.points:
                    break
                results.append(result)
                if k >= 1 and k + 1 < len(STATIONS):  # the repeat is shot without a choice
                    await survey.choose(ChooseTarget(result.station, 1), "bench")
        finally:
            await survey.cancel("bench over")
            await ptu.close()
    return results


async def run(seeds: range, scene: str, work: Path) -> dict[str, Counter]:
    counts = {name: Counter() for name in STATIONS}
    for seed in seeds:
        for name, result in zip(STATIONS, await walk(seed, scene, work), strict=False):
            for p in result.points:
                counts[name][clause(p.why)] += 1
                print(f"seed {seed} {name:12s} #{p.rank} {p.why}")
    return counts


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench.novelty", description=__doc__.splitlines()[0])
    ap.add_argument("--walks", type=int, default=3)
    ap.add_argument("--seed", type=int, default=1000, help="the first walk's seed")
    ap.add_argument("--scene", choices=("world", "outcrop"), default="world")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="bench-novelty-") as tmp:
        seeds = range(args.seed, args.seed + args.walks)
        counts = asyncio.run(run(seeds, args.scene, Path(tmp)))
    if args.json:
        print(json.dumps({k: dict(v) for k, v in counts.items()}, indent=1))
        return 0
    print(
        f"{args.walks} walks (seeds {args.seed}+) on sim://{args.scene}: memory clauses per station"
    )
    for name, c in counts.items():
        total = sum(c.values())
        print(
            f"{name:12s} new {c['new']:2d}/{total:2d}  ranked {c['ranked']:2d}  "
            f"seen {c['seen']:2d}  none {c['none']:2d}"
        )
    print(f"wall time {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
