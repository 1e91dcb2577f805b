"""PTU benchmark: command round trips over the pty and the emulator's move-time fidelity.

Round trip: a position query (``PP``) through the real serial driver and a pty, with the
line paced at 9600 baud like the real unit, and unpaced; the baseline is the same query
on the in-process emulator (no pty, no driver I/O) and the bare line time of the bytes
exchanged (``PP `` out, ``* 1234\\r\\n`` back, 10 bits a byte), both from the same run.

Fidelity: moves of several sizes timed from sending ``PP``/``TP`` to the unit's ``A``
reply (it answers when motion ends), in emulated seconds (wall × time scale), against
:func:`daemon.ptu.motion.move_time`. The difference is what a driver sees beyond the
model: line time of the command and of the reply, and the emulator's 2 ms tick.

Surveys through a noisy line: whole stations (the real survey engine, a real vision
worker, the simulated camera, the real serial driver on a pty paced at 9600 baud), each on
a fresh unit, counted complete or failed. Faults: one 16-byte noise burst glued onto a
random reply of the survey; sustained noise (a 16-byte burst put on the line every 0.5 to
1.5 s, wherever the line is, mid-reply included); one reply delayed 2 s at a random point
(everything behind it waits too). The baseline is the same surveys on a clean line.

Usage: ``python -m bench.ptu [--queries 300] [--time-scale 10] [--surveys 12] [--json]``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import random
import sys
import tempfile
import time
from pathlib import Path

from bench.stats import latency
from cyborg.daemon.archive import Archive
from cyborg.daemon.camera import open_camera
from cyborg.daemon.config import SurveyConfig
from cyborg.daemon.ptu import EmulatedPtu, PtyPtu
from cyborg.daemon.ptu.commanded import CommandedPtu
from cyborg.daemon.ptu.emulator import Ptu46Emulator
from cyborg.daemon.ptu.motion import move_time
from cyborg.daemon.ptu.ptyserver import Fault
from cyborg.daemon.rig import Rig
from cyborg.daemon.survey import Survey, SurveyTelemetry
from cyborg.daemon.worker import VisionWorker
from cyborg.protocol.messages import SurveyStart

MOVES = [("pan", 5.0), ("pan", 30.0), ("pan", 90.0), ("pan", 300.0), ("tilt", 20.0), ("tilt", 70.0)]
SURVEY_TIME_SCALE = 10.0
BURST = 16


async def _round_trips(unit: CommandedPtu, n: int) -> dict[str, float]:
    await unit._int("PP")
    samples = []
    for _ in range(n):
        t0 = time.perf_counter()
        await unit._int("PP")
        samples.append(time.perf_counter() - t0)
    return latency(samples)


async def round_trips(n: int) -> dict[str, dict[str, float]]:
    out: dict[str, dict[str, float]] = {}
    async with EmulatedPtu(Ptu46Emulator()) as unit:
        out["in-process emulator (baseline)"] = await _round_trips(unit, n)
    async with PtyPtu(Ptu46Emulator(), baud=0) as unit:
        out["pty, unpaced"] = await _round_trips(unit, n)
    async with PtyPtu(Ptu46Emulator()) as unit:
        out["pty, paced at 9600 baud"] = await _round_trips(unit, n)
    line = (len(b"PP ") + len(b"* 0\r\n")) * 10 / 9600
    out["line time at 9600 baud (baseline)"] = {"median_ms": 1e3 * line, "p99_ms": 1e3 * line}
    return out


async def fidelity(time_scale: float) -> list[dict[str, float | str]]:
    rows: list[dict[str, float | str]] = []
    emu = Ptu46Emulator(time_scale=time_scale)
    async with PtyPtu(emu) as unit:
        for axis, degrees in MOVES:
            info = unit.info.pan if axis == "pan" else unit.info.tilt
            lo = info.min_deg + 0.5
            start = lo if degrees < info.max_deg - lo else info.min_deg + 0.1
            await unit.move_to(**{axis: start})
            target = info.to_positions(start + degrees)
            cmd = "PP" if axis == "pan" else "TP"
            t0 = emu.now()
            await unit._do(cmd, target)
            await unit._do("A", timeout=60.0)
            measured = emu.now() - t0
            distance = target - info.to_positions(start)
            predicted = move_time(distance, info.speed, info.base, info.accel)
            rows.append(
                {
                    "move": f"{axis} {degrees:g} deg",
                    "positions": distance,
                    "predicted_s": predicted,
                    "measured_s": measured,
                    "overhead_ms": 1e3 * (measured - predicted) / time_scale,
                    "ratio": measured / predicted,
                }
            )
    return rows


async def _noise(unit: PtyPtu, rng: random.Random) -> None:
    while True:
        await asyncio.sleep(rng.uniform(0.5, 1.5))
        unit.server.inject(rng.randbytes(BURST))


async def _station(
    worker: VisionWorker, root: Path, rng: random.Random, fault: str, commands: int
) -> tuple[bool, int]:
    """One 2 x 3 station on a fresh unit, the fault striking once the unit is initialised;
    (completed, commands the survey sent)."""
    emulator = Ptu46Emulator(time_scale=SURVEY_TIME_SCALE)
    unit = PtyPtu(emulator)
    rig = Rig(unit, lambda pose: open_camera("sim://outcrop?seed=3", pose=pose))
    archive = Archive(root, "bench")
    archive.open()

    def ignore(*_: object) -> None:
        pass

    telemetry = SurveyTelemetry(ignore, ignore, ignore, ignore)
    survey = Survey(rig, worker, archive, SurveyConfig(), hfov=30.0, telemetry=telemetry)
    async with unit, asyncio.TaskGroup() as tg:
        initialised = emulator.commands_seen
        nth = rng.randint(1, commands)
        if fault == "burst":
            unit.server.faults.append(Fault("noise", nth=nth, data=rng.randbytes(BURST)))
        elif fault == "delay":
            unit.server.faults.append(Fault("delay", nth=nth, seconds=2.0))
        noise = tg.create_task(_noise(unit, rng)) if fault == "sustained" else None
        survey.start(SurveyStart(rows=2, cols=3), "bench")
        assert survey._task is not None
        await survey._task
        sent = emulator.commands_seen - initialised
        if noise:
            noise.cancel()
    assert survey.station is not None
    return survey.station.manifest["status"] == "complete", sent


async def surveys(n: int, seed: int = 41) -> dict[str, dict[str, float]]:
    """Stations completed of ``n`` per line condition, clean line first (the baseline)."""
    rng = random.Random(seed)
    out: dict[str, dict[str, float]] = {}
    commands = 1
    with tempfile.TemporaryDirectory(prefix="bench-ptu-") as tmp:
        async with VisionWorker() as worker:
            for fault in ("clean", "burst", "sustained", "delay"):
                done, seen = 0, []
                for k in range(n):
                    root = Path(tmp) / f"{fault}{k}"
                    ok, count = await _station(worker, root, rng, fault, commands)
                    done += ok
                    seen.append(count)
                if fault == "clean":
                    commands = min(seen)  # faults strike within what a survey sends
                out[fault] = {"completed": done, "of": n, "commands": sum(seen) / n}
    return out


def _print_round_trips(trips: dict, moves: list, queries: int, time_scale: float) -> None:
    base = trips["in-process emulator (baseline)"]["median_ms"]
    print(f"PTU command round trip (PP query), {queries} queries")
    print(f"{'path':36s} {'median ms':>9s} {'p99 ms':>8s} {'x baseline':>10s}")
    for name, s in trips.items():
        print(f"{name:36s} {s['median_ms']:9.3f} {s['p99_ms']:8.3f} {s['median_ms'] / base:10.1f}")
    print(f"\nmove time fidelity (emulated seconds, time scale {time_scale:g}, timed by A)")
    head = ("move", "positions", "model s", "measured s", "ratio", "extra ms (wall)")
    print("{:16s} {:>9s} {:>8s} {:>10s} {:>6s} {:>16s}".format(*head))
    for r in moves:
        print(
            f"{r['move']:16s} {r['positions']:9d} {r['predicted_s']:8.3f} "
            f"{r['measured_s']:10.3f} {r['ratio']:6.3f} {r['overhead_ms']:16.1f}"
        )


_LINES = {
    "clean": "clean line (baseline)",
    "burst": "one 16-byte noise burst",
    "sustained": "sustained noise (a burst every ~1 s)",
    "delay": "one reply delayed 2 s",
}


def _print_surveys(stations: dict[str, dict[str, float]]) -> None:
    print(
        f"\n2 x 3 surveys through a faulty line (pty, 9600 baud, time scale {SURVEY_TIME_SCALE:g})"
    )
    print(f"{'line':36s} {'completed':>9s} {'commands/survey':>16s}")
    for name, r in stations.items():
        print(f"{_LINES[name]:36s} {r['completed']:>4.0f} of {r['of']:<2.0f} {r['commands']:16.0f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--queries", type=int, default=300)
    ap.add_argument("--time-scale", type=float, default=1.0)
    ap.add_argument("--surveys", type=int, default=12, help="per line condition; 0 skips")
    ap.add_argument("--surveys-only", action="store_true")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    trips = {} if args.surveys_only else asyncio.run(round_trips(args.queries))
    moves = [] if args.surveys_only else asyncio.run(fidelity(args.time_scale))
    stations = asyncio.run(surveys(args.surveys)) if args.surveys else {}
    if args.json:
        print(json.dumps({"round_trip": trips, "moves": moves, "surveys": stations}, indent=2))
        return 0
    if trips:
        _print_round_trips(trips, moves, args.queries, args.time_scale)
    if stations:
        _print_surveys(stations)
    return 0


if __name__ == "__main__":
    sys.exit(main())
