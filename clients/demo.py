"""``cyborg demo``: a complete simulated field day through the bus.

Starts ``cyborgd`` with the PTU-46 emulator on a pseudo-terminal (the real serial
driver at 9600 baud) and the simulated PAL camera on a procedural world with detail at
every range, then acts as the field scientist: take control, survey, choose the top
target, walk closer (the simulated camera magnifies by the distance ratio), survey again
with the mosaic the rig fitted to the target (the one its choice reply announces), down
to 10 m.
"""

from __future__ import annotations

import asyncio
import json
import sys
import time
from pathlib import Path

from cyborg.protocol.messages import (
    ChooseTarget,
    InterestResult,
    SurveyProgress,
    SurveyStart,
    TakeControl,
)
from cyborg.protocol.transport import Transport

from .launch import free_port, launch, simulated_config
from .rigclient import RigClient, RigError, run_station

__all__ = ["run_demo"]

RIG = "demo"


async def _demo(out: Path, time_scale: float, seed: int) -> int:
    out.mkdir(parents=True, exist_ok=True)
    archive = (out / "archive").resolve()
    port = free_port()
    config = out / "cyborgd.toml"
    config.write_text(
        simulated_config(
            RIG,
            archive,
            listen=[f"tcp/127.0.0.1:{port}"],
            time_scale=time_scale,
            seed=seed,
            scene="world",
            frame_rate=5,
            survey={"approach": [300, 60, 10], "simulate_approach": True},
        )
    )
    t0 = time.perf_counter()
    async with launch(["--config", str(config)], out / "cyborgd.log") as daemon:
        print(f"cyborgd running (pid {daemon.pid}), PTU emulator on a pty, simulated camera")
        with RigClient.open(
            Transport(connect=(f"tcp/127.0.0.1:{port}",)), RIG, "demo-scientist"
        ) as client:
            await client.wait_alive()
            progress = client.subscribe(client.keys.progress, SurveyProgress)
            results = client.subscribe(client.keys.result, InterestResult)
            await client.command(TakeControl())
            request = SurveyStart(rows=2, cols=3, downsample=4.0)
            stations = []
            for _ in range(3):  # 300, 60, 10 m
                result = await run_station(client, progress, results, request)
                stations.append(result)
                print(f"\nstation {result.station}: mosaic {result.width}x{result.height}")
                for p in result.points:
                    print(f"  #{p.rank} pan {p.pan:7.2f} tilt {p.tilt:6.2f} score {p.score:5.2f}")
                    print(f"       {p.why}")
                best = next((p for p in result.points if p.target), None)
                if best is None:  # nothing stands out from this view: nothing to walk to
                    break
                ack = await client.command(ChooseTarget(result.station, best.rank))
                print(f"  chose #{best.rank}: {ack.detail}")
                request = SurveyStart(downsample=4.0)  # the mosaic the rig fitted
        code = await daemon.stop()
    print(f"\ncyborgd stopped with exit status {code} after {time.perf_counter() - t0:.1f} s")
    print(f"archive: {archive}")
    for result in stations:
        folder = archive / result.station
        manifest = json.loads((folder / "manifest.json").read_text())
        print(f"  {folder}/  ({manifest['status']}, {manifest['distance_m']:g} m)")
        maps = folder / "analysis"
        print(f"    overlay   {maps / 'overlay.png'}")
        print(f"    maps      {maps}/{{segmentation,uncommon}}_{{h,s,i}}.png, interest.png")
        print(f"    figures   {maps}/figure_*.png (each map with its legend or scale)")
        print(f"    mosaic    {folder / 'mosaic.png'}; chips in {folder / 'chips'}/")
    for session in sorted({result.station.split("/")[0] for result in stations}):
        log = archive / session / "session.mcap"
        print(f"report      {archive / session / 'report.html'}  (prints on A4, a page a station)")
        print(f"session log {log}  (Foxglove opens it; cyborg replay {archive / session})")
    return code


def run_demo(out: Path, time_scale: float = 4.0, seed: int = 3) -> int:
    try:
        return asyncio.run(_demo(out, time_scale, seed))
    except (RigError, RuntimeError) as exc:
        print(f"cyborg demo: {exc}", file=sys.stderr)
        return 1
