"""Survey benchmark: a station's wall time against what the hardware alone needs.

``cyborgd`` runs as a real process with the PTU-46 emulator on a pty (the real serial
driver, the line paced at 9600 baud, the head moving in real time unless
``--time-scale`` says otherwise) and the simulated PAL camera. A client surveys a
rows × cols mosaic and takes the three chips, several times. The lower bound, from the
same runs, is the emulator's own motion model for every move the survey made plus the
time spent grabbing frames: no driver, no bus, no analysis, no file. The ratio says
what everything else costs; goal ≤ 1.10.

Conditions: nobody watching the live view, and one client watching at 10 fps.

Usage: ``python -m bench.survey [--runs 3] [--rows 2 --cols 3] [--time-scale 1] [--overlap 0]
[--json]``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import statistics
import sys
import tempfile
from pathlib import Path

from cyborg.clients.launch import free_port, launch, simulated_config
from cyborg.clients.rigclient import RigClient, run_station
from cyborg.protocol.messages import InterestResult, SurveyProgress, SurveyStart, TakeControl
from cyborg.protocol.transport import Transport


async def _condition(
    work: Path,
    rows: int,
    cols: int,
    *,
    runs: int,
    time_scale: float,
    watch: bool,
    overlap: float = 0.0,
) -> dict:
    port = free_port()
    archive = work / f"archive-{'watched' if watch else 'unwatched'}"
    config = work / f"bench-{port}.toml"
    config.write_text(
        simulated_config(
            "bench",
            archive,
            listen=[f"tcp/127.0.0.1:{port}"],
            time_scale=time_scale,
            frame_rate=10.0 if watch else 0.0,
            survey={"overlap": overlap},
        )
    )
    async with launch(["--config", str(config)], work / "cyborgd.log"):
        with RigClient.open(Transport(connect=(f"tcp/127.0.0.1:{port}",)), "bench", "bench") as c:
            await c.wait_alive()
            progress, results = (
                c.subscribe(c.keys.progress, SurveyProgress),
                c.subscribe(c.keys.result, InterestResult),
            )
            frames = c.frames() if watch else None
            await c.command(TakeControl())
            stations = []
            for run in range(runs):
                # Alternate the centre so every run starts with a real slew (inside the cliff).
                req = SurveyStart(rows=rows, cols=cols, pan0=-3.0 if run % 2 else 3.0)
                stations.append((await run_station(c, progress, results, req)).station)
            seen = frames.qsize() if frames is not None else 0
    rows_out = []
    for station in stations:
        t = json.loads((archive / station / "manifest.json").read_text())["timing"]
        motion = t["predicted_motion_s"] / time_scale
        bound = motion + t["grab_s"]
        rows_out.append(
            {
                "wall_s": t["wall_s"],
                "motion_model_s": motion,
                "grab_s": t["grab_s"],
                "analysis_s": t["analysis_s"],
                "compose_s": t.get("compose_s", 0.0),
                "lower_bound_s": bound,
                "ratio": t["wall_s"] / bound,
            }
        )
    return {
        "watched": watch,
        "frames_received": seen,
        "runs": rows_out,
        "median_ratio": statistics.median(r["ratio"] for r in rows_out),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench.survey", description=__doc__)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--rows", type=int, default=2)
    ap.add_argument("--cols", type=int, default=3)
    ap.add_argument("--time-scale", type=float, default=1.0)
    ap.add_argument("--overlap", type=float, default=0.0, help="tiles' overlap (registered)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="bench-survey-") as tmp:
        out = [
            asyncio.run(
                _condition(
                    Path(tmp),
                    args.rows,
                    args.cols,
                    runs=args.runs,
                    time_scale=args.time_scale,
                    watch=watch,
                    overlap=args.overlap,
                )
            )
            for watch in (False, True)
        ]
    if args.json:
        print(json.dumps(out, indent=1))
        return 0
    print(
        f"survey of a {args.rows}x{args.cols} mosaic (overlap {args.overlap:g}) + 3 chips, PTU "
        f"emulator on a pty at 9600 baud, time scale {args.time_scale:g}"
    )
    print(
        f"{'live view':<12} {'wall s':>7} {'motion s':>9} {'grab s':>7} {'analysis s':>11} "
        f"{'compose s':>10} {'bound s':>8} {'ratio':>6}"
    )
    for cond in out:
        for r in cond["runs"]:
            print(
                f"{'watched' if cond['watched'] else 'off':<12} {r['wall_s']:7.2f} "
                f"{r['motion_model_s']:9.2f} {r['grab_s']:7.3f} {r['analysis_s']:11.3f} "
                f"{r['compose_s']:10.3f} {r['lower_bound_s']:8.2f} {r['ratio']:6.3f}"
            )
    for cond in out:
        name = "watched" if cond["watched"] else "live view off"
        print(f"median ratio ({name}): {cond['median_ratio']:.3f}  (goal <= 1.10)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
