"""PTU benchmark: command round trips over the pty and the emulator's move-time fidelity.

Round trip: a position query (``PP``) through the real serial driver and a pty, with the
line paced at 9600 baud like the real unit, and unpaced; the baseline is the same query
on the in-process emulator (no pty, no driver I/O) and the bare line time of the bytes
exchanged (``PP `` out, ``* 1234\\r\\n`` back, 10 bits a byte), both from the same run.

Fidelity: moves of several sizes timed from sending ``PP``/``TP`` to the unit's ``A``
reply (it answers when motion ends), in emulated seconds (wall × time scale), against
:func:`daemon.ptu.motion.move_time`. The difference is what a driver sees beyond the
model: line time of the command and of the reply, and the emulator's 2 ms tick.

Usage: ``python -m bench.ptu [--queries 300] [--time-scale 10] [--json]``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import sys
import time

from bench.stats import latency
from daemon.ptu import EmulatedPtu, PtyPtu
from daemon.ptu.commanded import CommandedPtu
from daemon.ptu.emulator import Ptu46Emulator
from daemon.ptu.motion import move_time

MOVES = [("pan", 5.0), ("pan", 30.0), ("pan", 90.0), ("pan", 300.0), ("tilt", 20.0), ("tilt", 70.0)]


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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--queries", type=int, default=300)
    ap.add_argument("--time-scale", type=float, default=1.0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    trips = asyncio.run(round_trips(args.queries))
    moves = asyncio.run(fidelity(args.time_scale))
    if args.json:
        print(json.dumps({"round_trip": trips, "moves": moves}, indent=2))
        return 0
    base = trips["in-process emulator (baseline)"]["median_ms"]
    print(f"PTU command round trip (PP query), {args.queries} queries")
    print(f"{'path':36s} {'median ms':>9s} {'p99 ms':>8s} {'x baseline':>10s}")
    for name, s in trips.items():
        print(f"{name:36s} {s['median_ms']:9.3f} {s['p99_ms']:8.3f} {s['median_ms'] / base:10.1f}")
    print(f"\nmove time fidelity (emulated seconds, time scale {args.time_scale:g}, timed by A)")
    head = ("move", "positions", "model s", "measured s", "ratio", "extra ms (wall)")
    print("{:16s} {:>9s} {:>8s} {:>10s} {:>6s} {:>16s}".format(*head))
    for r in moves:
        print(
            f"{r['move']:16s} {r['positions']:9d} {r['predicted_s']:8.3f} "
            f"{r['measured_s']:10.3f} {r['ratio']:6.3f} {r['overhead_ms']:16.1f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
