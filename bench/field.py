"""Field-day benchmark: the rig as a bad day in the field treats it.

``cyborgd`` runs as a real process (PTU-46 emulator on a pty behind the real serial
driver, simulated camera, live view at 10 fps, a real vision worker), listening on
loopback TCP; every other party is a separate zenoh session linked straight to it.

- **frozen viewer**: a viewer process subscribed to everything (``cyborg/<rig>/**``) is
  frozen with SIGSTOP, as a laptop whose radio link stalls; meanwhile surveys run and a
  controller sends HALT. Latency of HALT (round trip of ``ptu/halt``) before and while
  the viewer is frozen.
- **cancel**: ``survey/cancel`` or HALT while the station is at its analysis, then a new
  ``survey/start``: how many next stations complete, how many cancelled stations keep a
  partial analysis folder, and how long the cancel takes.
- **idle**: the daemon's CPU (user + system, % of one core) over ``--idle`` seconds with
  the live view on and nobody watching, and with the live view off (the floor).
- **oversize**: ``hello`` requests of 256 MiB each, eight in flight from one client: the
  daemon's peak RSS and a HALT's latency from another client meanwhile.

Usage: ``python -m bench.field [--halts 20] [--rounds 6] [--idle 20] [--json]``.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import signal
import sys
import tempfile
import time
from collections.abc import AsyncIterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from bench.stats import latency
from cyborg.clients.launch import Daemon, free_port, launch, simulated_config, watcher
from cyborg.clients.rigclient import RigClient, RigError, until_stage
from cyborg.protocol.envelope import encode
from cyborg.protocol.keys import Keys
from cyborg.protocol.messages import (
    Hello,
    InterestResult,
    PtuHalt,
    SurveyCancel,
    SurveyProgress,
    SurveyStart,
    TakeControl,
)
from cyborg.protocol.transport import Transport
from cyborg.protocol.version import PROTOCOL_MAJOR, PROTOCOL_MINOR

RIG = "fieldbench"


@contextlib.asynccontextmanager
async def _rig(tmp: Path, frame_rate: float = 10.0) -> AsyncIterator[tuple[Daemon, str]]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    tmp.mkdir(parents=True, exist_ok=True)
    config = tmp / f"field-{frame_rate:g}.toml"
    config.write_text(
        simulated_config(
            RIG, tmp / "archive", listen=[endpoint], frame_rate=frame_rate, time_scale=8
        )
    )
    async with launch(["--config", str(config)], tmp / "cyborgd.log") as daemon:
        yield daemon, endpoint


def _client(endpoint: str, name: str) -> contextlib.AbstractContextManager[RigClient]:
    return RigClient.open(Transport("client", connect=(endpoint,)), RIG, name)


async def _halt(client: RigClient) -> float:
    t0 = time.perf_counter()
    await client.command(PtuHalt(), timeout=30.0)
    return time.perf_counter() - t0


async def frozen_viewer(tmp: Path, halts: int) -> dict:
    """HALT latency with every publication also going to a viewer that stopped reading."""
    async with _rig(tmp) as (_, endpoint), watcher(endpoint, f"{Keys(RIG).root}/**") as viewer:
        with _client(endpoint, "bench") as client:
            await client.wait_alive()
            await client.command(TakeControl())
            before = [await _halt(client) for _ in range(halts)]
            viewer.send_signal(signal.SIGSTOP)
            frozen = []
            for _ in range(halts):
                await client.command(SurveyStart(rows=2, cols=3), timeout=30.0)
                await asyncio.sleep(0.5)  # frames, progress and events pile up
                frozen.append(await _halt(client))
    return {
        "before": latency(before) | {"max_ms": 1e3 * max(before)},
        "frozen": latency(frozen) | {"max_ms": 1e3 * max(frozen)},
    }


async def cancel_in_analysis(tmp: Path, rounds: int) -> dict:
    """Cancel (or HALT) at the analysis stage, then a new station: does it complete?"""
    async with _rig(tmp, frame_rate=0.0) as (daemon, endpoint):
        with _client(endpoint, "b") as client:
            await client.wait_alive()
            await client.command(TakeControl())
            return await _cancel_rounds(client, Path(daemon.ready["archive"]), rounds)


async def _cancel_rounds(client: RigClient, archive: Path, rounds: int) -> dict:
    completed, partials, cancel_s = 0, 0, []
    progress = client.subscribe(client.keys.progress, SurveyProgress)
    results = client.subscribe(client.keys.result, InterestResult)
    for i in range(rounds):
        request = SurveyStart(rows=2, cols=3, downsample=1.0)
        station = (await client.command(request, timeout=30.0)).detail
        await until_stage(progress, station, {"analysis"})
        t0 = time.perf_counter()
        await client.command(PtuHalt() if i % 2 else SurveyCancel(), timeout=30.0)
        await until_stage(progress, station, {"incomplete", "failed", "done"})
        cancel_s.append(time.perf_counter() - t0)
        partials += (archive / station / ".analysis.partial").exists()
        try:
            nxt = (await client.command(SurveyStart(rows=1, cols=2), timeout=30.0)).detail
            final = await until_stage(progress, nxt, {"done", "failed", "incomplete"})
        except (RigError, TimeoutError) as exc:
            print(f"round {i + 1}: the next station did not complete: {exc!r}", file=sys.stderr)
            await client.command(SurveyCancel(), timeout=30.0)
            continue
        if final.stage == "done":
            completed += 1
            await results.get()
    return {
        "rounds": rounds,
        "next_completed": completed,
        "partial_left": partials,
        "cancel": latency(cancel_s),
    }


def _cpu_seconds(pid: int) -> float:
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


async def idle(tmp: Path, seconds: float) -> dict:
    """The daemon's CPU with nobody watching, live view on (10 fps) and off."""
    out = {}
    for rate in (10.0, 0.0):
        async with _rig(tmp, frame_rate=rate) as (daemon, _):
            await asyncio.sleep(2.0)  # start-up settles
            c0, t0 = _cpu_seconds(daemon.pid), time.monotonic()
            await asyncio.sleep(seconds)
            used = _cpu_seconds(daemon.pid) - c0
            out[f"frames_{rate:g}fps"] = 100 * used / (time.monotonic() - t0)
    return out


def _rss_peak_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024
    return float("nan")


async def oversize(tmp: Path, size_mb: int = 256, in_flight: int = 8) -> dict:
    """Huge requests from one client; HALT from another meanwhile; the daemon's peak RSS."""
    # Each request waits in a thread of this process: enough threads that the HALT's own
    # round trip never queues behind them here.
    asyncio.get_running_loop().set_default_executor(ThreadPoolExecutor(in_flight + 8))
    async with _rig(tmp, frame_rate=0.0) as (daemon, endpoint):
        with _client(endpoint, "flood") as flood, _client(endpoint, "bench") as client:
            await client.wait_alive()
            baseline_mb = _rss_peak_mb(daemon.pid)
            hello = Hello(PROTOCOL_MAJOR, PROTOCOL_MINOR)
            big = encode(hello.KIND, hello.to_body()) + b"\0" * (size_mb << 20)
            tasks = [
                asyncio.create_task(flood.call_raw(hello.VERB, big, timeout=60.0))
                for _ in range(in_flight)
            ]
            await asyncio.sleep(1.0)
            halts = [await _halt(client) for _ in range(5)]
            replies = await asyncio.gather(*tasks, return_exceptions=True)
            alive = daemon.proc.returncode is None
            peak = _rss_peak_mb(daemon.pid) if alive else float("nan")
    return {
        "sent_mb": size_mb * in_flight,
        "rss_before_mb": baseline_mb,
        "rss_peak_mb": peak,
        "halt": latency(halts) | {"max_ms": 1e3 * max(halts)},
        "refused": sum(1 for r in replies if isinstance(r, Exception) or not r),
        "daemon_alive": alive,
    }


async def _run(args: argparse.Namespace) -> dict:
    report = {}
    with tempfile.TemporaryDirectory(prefix="bench-field-") as tmp:
        steps = {
            "frozen_viewer": lambda: frozen_viewer(Path(tmp) / "frozen", args.halts),
            "cancel": lambda: cancel_in_analysis(Path(tmp) / "cancel", args.rounds),
            "idle": lambda: idle(Path(tmp) / "idle", args.idle),
            "oversize": lambda: oversize(Path(tmp) / "oversize"),
        }
        for name in args.only or steps:
            report[name] = await steps[name]()
    return report


def _print(report: dict) -> None:
    if r := report.get("frozen_viewer"):
        b, f = r["before"], r["frozen"]
        print("HALT latency, one viewer of everything frozen by SIGSTOP (surveys running):")
        print(f"  before freezing  median {b['median_ms']:7.1f} ms   max {b['max_ms']:7.1f} ms")
        print(f"  frozen           median {f['median_ms']:7.1f} ms   max {f['max_ms']:7.1f} ms")
        print(f"  frozen / before (median): {f['median_ms'] / b['median_ms']:.2f}x")
    if r := report.get("cancel"):
        print(
            f"cancel or HALT at the analysis stage, then a new station: "
            f"{r['next_completed']} of {r['rounds']} next stations completed, "
            f"{r['partial_left']} partial analysis folders left; cancel took "
            f"{r['cancel']['median_ms']:.0f} ms (median)"
        )
    if r := report.get("idle"):
        print(
            f"idle daemon, nobody watching: {r['frames_10fps']:.1f} % of a core with the live "
            f"view at 10 fps, {r['frames_0fps']:.1f} % with it off (the floor)"
        )
    if r := report.get("oversize"):
        h = r["halt"]
        print(
            f"{r['sent_mb']} MB of hello in flight: daemon peak RSS {r['rss_peak_mb']:.0f} MB "
            f"(at rest {r['rss_before_mb']:.0f} MB); HALT median {h['median_ms']:.0f} ms, "
            f"max {h['max_ms']:.0f} ms; {r['refused']} of 8 refused; "
            f"daemon {'alive' if r['daemon_alive'] else 'DEAD'}"
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench.field", description=__doc__)
    ap.add_argument("--halts", type=int, default=20)
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--idle", type=float, default=20.0, help="seconds of idle measured")
    ap.add_argument(
        "--only", action="append", choices=("frozen_viewer", "cancel", "idle", "oversize")
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    report = asyncio.run(_run(args))
    if args.json:
        print(json.dumps(report, indent=1))
    else:
        _print(report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
