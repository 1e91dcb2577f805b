"""Target size benchmark: how big the rig says a target is, at 300, 60 and 10 m, against the
size the procedural world planted (:class:`cyborg.daemon.sim.world.World`).

Each world is walked as ``cyborgd`` walks it (the survey engine in-process, the PTU-46
emulator, a real vision worker, ``sim://world?seed=N``, the approach simulated by the lens):
the 300 m mosaic centred on the wet stain, then at each station the point nearest the stain's
core chosen. At 300 and 60 m the target is the stain (radius 1.2-1.8 deg as seen from 300 m);
at 10 m, where the stain fills the view, it is its shadowed core (a tenth of that). Per range
it prints the median ratio of the reported diameter (``2 radius_deg``) to the planted one,
and the same for the point's patch on the blurred interest map (``result.json``'s ``radius``
times the pixel scale: the size reported before it was measured on the image).

Usage: ``python -m bench.sizes [--worlds 5] [--json]``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

from cyborg.daemon.archive import Archive
from cyborg.daemon.camera import open_camera
from cyborg.daemon.config import SurveyConfig
from cyborg.daemon.pointing.geometry import MosaicGeometry
from cyborg.daemon.ptu import open_ptu
from cyborg.daemon.rig import Rig
from cyborg.daemon.sim.world import World
from cyborg.daemon.survey import Survey, SurveyTelemetry
from cyborg.daemon.worker import VisionWorker
from cyborg.protocol.messages import ChooseTarget, SurveyStart

from .approach import HEIGHT, HFOV, WIDTH


def _quiet() -> SurveyTelemetry:
    return SurveyTelemetry(lambda _p: None, lambda _r: None, lambda _c: None, lambda *_: None)


async def walk(seed: int, work: Path) -> list[dict]:
    """One approach on world ``seed``; per station: its range, the planted diameter of the
    target in view, the reported one and the patch's (degrees)."""
    world = World(seed)
    stain = world.target
    assert stain.close is not None
    ptu = open_ptu("emu://?time_scale=200")
    url = f"sim://world?seed={seed}&width={WIDTH}&height={HEIGHT}&hfov={HFOV}"
    rig = Rig(ptu, lambda pose: open_camera(url, pose=pose))
    archive = Archive(work / str(seed), "bench")
    archive.open()
    config = SurveyConfig(simulate_approach=True)
    rows = []
    async with VisionWorker() as worker:
        await ptu.open()
        survey = Survey(rig, worker, archive, config, hfov=HFOV, telemetry=_quiet())
        try:
            for leg, distance in enumerate(config.approach):
                first = SurveyStart(pan0=stain.pan, tilt0=stain.tilt)
                survey.start(first if leg == 0 else SurveyStart(), "bench")
                await survey._task
                result = survey._result
                if result is None or not result.points:
                    break
                whole = (stain.pan, stain.tilt, stain.radius)
                planted = stain.close if leg == len(config.approach) - 1 else whole
                pan, tilt, radius = planted
                point = min(result.points, key=lambda p: math.hypot(p.pan - pan, p.tilt - tilt))
                folder = survey.station.folder
                doc = json.loads((folder / "analysis" / "result.json").read_text())
                patch = next(p["radius"] for p in doc["points"] if p["rank"] == point.rank)
                scale = MosaicGeometry.from_plan(survey.station.manifest["plan"]).degrees_per_pixel
                rows.append(
                    {
                        "seed": seed,
                        "range_m": distance,
                        "planted_deg": 2 * radius,
                        "reported_deg": 2 * (point.radius_deg or 0.0),
                        "patch_deg": 2 * patch * scale,
                        "off_deg": math.hypot(point.pan - pan, point.tilt - tilt),
                    }
                )
                if leg + 1 < len(config.approach):
                    await survey.choose(ChooseTarget(result.station, point.rank), "bench")
        finally:
            await survey.cancel("bench over")
            await ptu.close()
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench.sizes", description=__doc__.splitlines()[0])
    ap.add_argument("--worlds", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()

    async def run(work: Path) -> list[dict]:
        return [row for k in range(args.worlds) for row in await walk(1000 + k, work)]

    with tempfile.TemporaryDirectory(prefix="bench-sizes-") as tmp:
        rows = asyncio.run(run(Path(tmp)))
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print(f"target sizes: {args.worlds} seeded worlds (1000+), diameter / planted diameter")
    print(f"{'range':>7s} {'n':>3s} {'reported':>9s} {'patch (before)':>15s}")
    for distance in SurveyConfig().approach:
        at = [r for r in rows if r["range_m"] == distance]
        if not at:
            continue
        reported = statistics.median(r["reported_deg"] / r["planted_deg"] for r in at)
        patch = statistics.median(r["patch_deg"] / r["planted_deg"] for r in at)
        print(f"{distance:6g}m {len(at):3d} {reported:9.2f} {patch:15.2f}")
    print(f"wall time {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
