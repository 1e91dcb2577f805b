"""Session-log benchmark: what a SIGKILL costs the log, and what a restart gives back.

``cyborgd`` runs as a real process (PTU-46 emulator on a pty, simulated PAL camera, the
shipped 10 fps live view). A client surveys one whole station, starts a second and the
daemon is SIGKILLed once ``--tiles`` tiles of it are in: with the log's 1 fps of frames
and with none (``[record] frames = 0``, where the log fills slowest); and, with none,
after ``--idle`` seconds awaiting the scientist's choice. On the file as the kill left
it: the messages the mcap library's raw stream reader gets, what its ordinary reader
(``make_reader(f).iter_messages()``) does, and the longest time one of its whole chunks
was held open (first to last message). The daemon is started again on the same archive
and the ordinary reader tried once more; then, how many seconds before the kill the last
readable message was logged, and how much of the survey progress the client saw on the
bus the log does not hold.

Usage: ``python -m bench.record [--runs 3] [--tiles 4] [--idle 20] [--time-scale 1] [--json]``.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import signal
import statistics
import sys
import tempfile
import time
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Chunk, Message
from mcap.stream_reader import StreamReader, breakup_chunk

from cyborg.clients.launch import free_port, simulated_config, spawn
from cyborg.clients.rigclient import RigClient, run_station
from cyborg.protocol import recording as rec
from cyborg.protocol.messages import InterestResult, SurveyProgress, SurveyStart, TakeControl
from cyborg.protocol.transport import Transport

RIG = "recbench"


def _ordinary(path: Path) -> tuple[int, str]:
    """(messages, error name or "") of the mcap library's ordinary reader."""
    count = 0
    try:
        with path.open("rb") as f:
            for _ in make_reader(f).iter_messages():
                count += 1
    except (McapError, EOFError, ValueError) as exc:
        return count, type(exc).__name__
    return count, ""


def _raw(path: Path) -> tuple[list[int], float, int]:
    """(log times of the messages in the whole chunks the raw stream reader gets, the
    longest span of a chunk in s, survey progress messages among them)."""
    times: list[int] = []
    span = 0.0
    progress: set[int] = set()
    progress_count = 0
    with path.open("rb") as f, contextlib.suppress(McapError, EOFError, ValueError):
        for record in StreamReader(f, emit_chunks=True).records:
            if isinstance(record, Chunk):
                span = max(span, (record.message_end_time - record.message_start_time) / 1e9)
                for r in breakup_chunk(record):
                    if isinstance(r, Channel) and r.topic == rec.TOPICS["survey.progress"]:
                        progress.add(r.id)
                    elif isinstance(r, Message):
                        times.append(r.log_time)
                        progress_count += r.channel_id in progress
    return times, span, progress_count


async def _one(work: Path, frames: float, tiles: int, idle: float, time_scale: float) -> dict:
    """A station, then the kill: ``tiles`` tiles into the next one, or (``tiles`` 0) after
    ``idle`` seconds awaiting a choice."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    config = work / "rig.toml"
    config.write_text(
        simulated_config(
            RIG,
            work / "archive",
            listen=[endpoint],
            time_scale=time_scale,
            sections={"record": {"frames": frames}},
        )
    )
    seen: list[SurveyProgress] = []
    daemon = await spawn(["--config", str(config)], work / "cyborgd.log")
    try:
        with RigClient.open(Transport(connect=(endpoint,)), RIG, "bench") as client:
            await client.wait_alive()
            progress = client.subscribe(client.keys.progress, SurveyProgress)
            results = client.subscribe(client.keys.result, InterestResult)
            await client.command(TakeControl())
            first = await run_station(
                client, progress, results, SurveyStart(rows=2, cols=3), on_progress=seen.append
            )
            if tiles:
                station = (await client.command(SurveyStart(rows=2, cols=3))).detail
                async with asyncio.timeout(120):
                    while True:
                        p = await progress.get()
                        seen.append(p)
                        if p.station == station and p.stage == "tiles" and p.done >= tiles:
                            break
            else:
                await asyncio.sleep(idle)
        killed = time.time_ns()
        daemon.proc.send_signal(signal.SIGKILL)
        await daemon.proc.wait()
    finally:
        await daemon.stop()
    log = work / "archive" / first.station.split("/")[0] / "session.mcap"
    size = log.stat().st_size
    times, span, _ = _raw(log)
    before = _ordinary(log)
    again = await spawn(["--config", str(config)], work / "cyborgd.log")
    await again.stop()
    after = _ordinary(log)
    recovered, _, logged = _raw(log)
    return {
        "case": f"{tiles} tiles into station 2" if tiles else f"idle {idle:g} s after a station",
        "frames": frames,
        "bytes": size,
        "raw_messages": len(times),
        "ordinary_before": before,
        "ordinary_after_restart": after,
        "recovered_messages": len(recovered),
        "seconds_lost": (killed - max(recovered or times or [killed])) / 1e9,
        "longest_chunk_s": span,
        "progress_lost": f"{len(seen) - logged} of {len(seen)}",
    }


async def _run(runs: int, tiles: int, idle: float, time_scale: float) -> list[dict]:
    rows = []
    for frames, kill_at in ((1.0, tiles), (0.0, tiles), (0.0, 0)):
        for _ in range(runs):
            with tempfile.TemporaryDirectory(prefix="bench-record-") as tmp:
                rows.append(await _one(Path(tmp), frames, kill_at, idle, time_scale))
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench.record", description=__doc__)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--tiles", type=int, default=4, help="tiles of the 2nd station before the kill")
    ap.add_argument("--idle", type=float, default=20.0, help="seconds idle before the kill")
    ap.add_argument("--time-scale", type=float, default=1.0, help="PTU emulator speed-up")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    rows = asyncio.run(_run(args.runs, args.tiles, args.idle, args.time_scale))
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print("SIGKILL, then a restart on the same archive")
    print(
        f"{'killed':>28} {'frames/s':>8} {'MB':>6} {'raw':>5} {'ordinary reader, killed':>28} "
        f"{'after restart':>22} {'lost s':>7} {'progress lost':>14} {'chunk s':>8}"
    )
    for r in rows:
        n0, e0 = r["ordinary_before"]
        n1, e1 = r["ordinary_after_restart"]
        print(
            f"{r['case']:>28} {r['frames']:8g} {r['bytes'] / 1e6:6.1f} {r['raw_messages']:5d} "
            f"{f'{n0} msgs {e0}'.strip():>28} {f'{n1} msgs {e1}'.strip():>22} "
            f"{r['seconds_lost']:7.1f} {r['progress_lost']:>14} {r['longest_chunk_s']:8.1f}"
        )
    print(
        f"seconds of log lost: median {statistics.median(r['seconds_lost'] for r in rows):.1f}, "
        f"max {max(r['seconds_lost'] for r in rows):.1f}; longest open chunk "
        f"{max(r['longest_chunk_s'] for r in rows):.1f} s; ordinary reader whole after restart: "
        f"{sum(not r['ordinary_after_restart'][1] for r in rows)} of {len(rows)}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
