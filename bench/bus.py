"""Bus benchmark: live-frame delivery to 1 and 16 subscribers, and whether it slows commands.

``cyborgd`` runs as a real process (PTU emulator on a pty at 9600 baud, simulated PAL
camera, live view at 25 fps, 720×576 JPEG). Subscribers are separate zenoh sessions
in this process, each linked straight to the daemon over loopback TCP (peer mode, no
shared memory: the cost a remote operator's link would see). Frame latency is the
subscriber's clock at the callback minus the daemon's clock at publication (same host,
same clock). Command latency is a client's round trip for ``hello`` (bus only) and
``ptu/goto`` to where the head already is (two serial commands at 9600 baud), measured
with the live view off (the baseline) and with 1 and 16 subscribers watching.

Then the live views a thin link can ask for (``cam/stream``): bandwidth, frame rate and
latency of one viewer at each setting, against the rig's own view.

Usage: ``python -m bench.bus [--seconds 5] [--commands 40] [--json]``.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import sys
import tempfile
import time
from pathlib import Path

import zenoh

from bench.stats import latency
from cyborg.clients.launch import free_port, launch, simulated_config
from cyborg.clients.rigclient import RigClient
from cyborg.protocol.envelope import decode
from cyborg.protocol.keys import Keys
from cyborg.protocol.link import on_thread, open_session
from cyborg.protocol.messages import Hello, PtuGoto, TakeControl
from cyborg.protocol.transport import Transport
from cyborg.protocol.version import PROTOCOL_MAJOR, PROTOCOL_MINOR

FPS = 25


class _Watcher:
    """One subscriber session recording each frame's delivery latency."""

    def __init__(self, endpoint: str, key: str | None = None) -> None:
        self.session = open_session(Transport(connect=(endpoint,)))
        self.samples: list[float] = []
        self.bytes = 0
        self.recording = False
        self.sub = self.session.declare_subscriber(
            key or Keys("busbench").frame, on_thread(self._on)
        )

    def _on(self, sample: zenoh.Sample) -> None:
        now = time.time_ns()
        if self.recording and sample.attachment is not None:
            self.samples.append((now - decode(sample.attachment.to_bytes()).ts) / 1e9)
            self.bytes += len(sample.payload) + len(sample.attachment)

    def close(self) -> None:
        self.sub.undeclare()
        self.session.close()


async def _commands(client: RigClient, n: int) -> dict[str, dict[str, float]]:
    here = PtuGoto(0.0, 0.0)
    out = {}
    for name, msg in (("hello", Hello(PROTOCOL_MAJOR, PROTOCOL_MINOR)), ("ptu/goto", here)):
        samples = []
        for _ in range(n):
            t0 = time.perf_counter()
            await client.call(msg)
            samples.append(time.perf_counter() - t0)
            await asyncio.sleep(0.02)
        out[name] = latency(samples)
    return out


async def _run(seconds: float, n_commands: int) -> dict[str, list[dict]]:
    results = []
    with tempfile.TemporaryDirectory(prefix="bench-bus-") as tmp:
        port = free_port()
        config = Path(tmp) / "bus.toml"
        config.write_text(
            simulated_config(
                "busbench", Path(tmp) / "archive", listen=[f"tcp/127.0.0.1:{port}"], frame_rate=FPS
            )
        )
        endpoint = f"tcp/127.0.0.1:{port}"
        async with launch(["--config", str(config)], Path(tmp) / "cyborgd.log"):
            with RigClient.open(Transport(connect=(endpoint,)), "busbench", "bench") as client:
                await client.wait_alive()
                await client.command(TakeControl())
                for n in (0, 1, 16):
                    watchers = [_Watcher(endpoint) for _ in range(n)]
                    try:
                        await asyncio.sleep(1.0)  # routes settle, the daemon sees watchers
                        for w in watchers:
                            w.recording = True
                        t0 = time.perf_counter()
                        cmds = await _commands(client, n_commands)
                        await asyncio.sleep(max(0.0, seconds - (time.perf_counter() - t0)))
                        elapsed = time.perf_counter() - t0
                        for w in watchers:
                            w.recording = False
                        row = {"subscribers": n, "commands": cmds}
                        if n:
                            every = [s for w in watchers for s in w.samples]
                            row["frames"] = latency(every)
                            row["fps_per_subscriber"] = len(every) / n / elapsed
                        results.append(row)
                    finally:
                        for w in watchers:
                            w.close()
                streams = await _streams(client, endpoint, seconds)
    return {"subscribers": results, "streams": streams}


STREAMS = [None, (10.0, 720, 80), (5.0, 640, 70), (2.0, 320, 50), (1.0, 320, 40)]
"""The rig's own view, then streams a viewer might ask for (fps, width, JPEG quality)."""


async def _streams(client: RigClient, endpoint: str, seconds: float) -> list[dict]:
    """One viewer at a time on each setting: its bandwidth, frame rate and latency."""
    rows = []
    for setting in STREAMS:
        key = await client.stream(*setting) if setting else None
        watcher = _Watcher(endpoint, key)
        try:
            await asyncio.sleep(1.0)
            watcher.recording = True
            await asyncio.sleep(seconds)
            watcher.recording = False
        finally:
            watcher.close()
        name = f"{setting[0]:g} fps, {setting[1]} px, q{setting[2]}" if setting else "rig's own"
        row: dict = {
            "view": name,
            "fps": len(watcher.samples) / seconds,
            "kbit_s": 8 * watcher.bytes / seconds / 1000,
        }
        if watcher.samples:
            row["frames"] = latency(watcher.samples)
        rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench.bus", description=__doc__)
    ap.add_argument("--seconds", type=float, default=5.0)
    ap.add_argument("--commands", type=int, default=40)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    report = asyncio.run(_run(args.seconds, args.commands))
    if args.json:
        print(json.dumps(report, indent=1))
        return 0
    rows = report["subscribers"]
    print(f"live frames 720x576 JPEG at {FPS} fps, loopback TCP, peer links, no shared memory")
    print(
        f"{'subscribers':>11} {'fps each':>8} {'frame p50':>10} {'frame p99':>10} "
        f"{'hello p50':>10} {'hello p99':>10} {'goto p50':>9} {'goto p99':>9}"
    )
    for r in rows:
        f = r.get("frames")
        c = r["commands"]
        print(
            f"{r['subscribers']:>11} {r.get('fps_per_subscriber', 0):8.1f} "
            + (f"{f['median_ms']:8.2f}ms {f['p99_ms']:8.2f}ms " if f else f"{'-':>10} {'-':>10} ")
            + f"{c['hello']['median_ms']:8.2f}ms {c['hello']['p99_ms']:8.2f}ms "
            f"{c['ptu/goto']['median_ms']:7.2f}ms {c['ptu/goto']['p99_ms']:7.2f}ms"
        )
    base = rows[0]["commands"]["ptu/goto"]["median_ms"]
    for r in rows[1:]:
        ratio = r["commands"]["ptu/goto"]["median_ms"] / base
        print(f"goto latency with {r['subscribers']} watching / with none: {ratio:.2f}x")
    print("\nlive views fitted to the link (cam/stream), one viewer each:")
    print(f"{'view':>22} {'fps':>6} {'kbit/s':>8} {'frame p50':>10} {'frame p99':>10}")
    full = report["streams"][0]["kbit_s"] or 1.0
    for r in report["streams"]:
        f = r.get("frames") or {"median_ms": float("nan"), "p99_ms": float("nan")}
        print(
            f"{r['view']:>22} {r['fps']:6.1f} {r['kbit_s']:8.0f} {f['median_ms']:8.2f}ms "
            f"{f['p99_ms']:8.2f}ms  ({r['kbit_s'] / full:.2f}x the rig's own)"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
