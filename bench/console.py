"""Console benchmark: a slow-header flood against ``cyborg operator`` in a small box.

``cyborg operator`` runs as a process with a low open-file limit (``--nofile``, 256 by
default, as on a small field computer), dialling a zenoh endpoint where nothing answers (the
page is served all the same). This process opens ``--connections`` sockets from the
operator's own address (127.0.0.1, the worst case: a per-peer cap cannot tell them apart),
sends each an unfinished request header, then one more header line every few seconds, and
notes when the console closes each. While they are open, the operator opens the printed
URL. Figures: how many were accepted, how long they stayed open (at most ``--hold``
seconds), whether the operator's request was served and how fast, and the tracebacks in
the console's log.

Usage: ``python -m bench.console [--connections 400] [--nofile 256] [--hold 30] [--json]``.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import aiohttp

from cyborg.clients.launch import free_port, operator

RIG = "consolebench"
TRICKLE_S = 2.0
"""A slow client's pace: one more header line this often, never the blank line."""


async def slow_header(host: str, port: int, hold: float) -> float | None:
    """One slow client: seconds until the console closed it (``hold`` if it never did);
    None if it was never accepted."""
    try:
        async with asyncio.timeout(5.0):
            reader, writer = await asyncio.open_connection(host, port)
    except (OSError, TimeoutError):
        return None
    start = time.monotonic()
    try:
        writer.write(f"GET / HTTP/1.1\r\nHost: {host}:{port}\r\n".encode())
        async with asyncio.timeout(hold):
            for n in range(1_000_000):
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(TRICKLE_S):
                        if not await reader.read(1024):
                            break  # closed by the console
                writer.write(f"X-Slow-{n}: 1\r\n".encode())
                await writer.drain()
    except (OSError, TimeoutError):
        pass
    finally:
        writer.close()
    return min(time.monotonic() - start, hold)


async def operator_request(url: str) -> dict:
    """The operator opens the printed URL while the flood is on; served, and how fast."""
    start = time.monotonic()
    try:
        async with (
            aiohttp.ClientSession(timeout=aiohttp.ClientTimeout(total=30)) as http,
            http.get(url, allow_redirects=False) as r,
        ):
            status = r.status
    except (aiohttp.ClientError, TimeoutError) as exc:
        return {"served": False, "error": type(exc).__name__, "seconds": time.monotonic() - start}
    return {"served": status == 303, "status": status, "seconds": time.monotonic() - start}


async def _run(connections: int, nofile: int, hold: float) -> dict:
    with tempfile.TemporaryDirectory(prefix="cyborg-console-") as tmp:
        log = Path(tmp) / "operator.log"
        connect = f"tcp/127.0.0.1:{free_port()}"  # nothing answers there: the page is enough
        async with operator(connect, RIG, "bench-op", log, nofile=nofile) as url:
            host, port = url.removeprefix("http://").split("/", 1)[0].rsplit(":", 1)
            flood = [
                asyncio.create_task(slow_header(host, int(port), hold)) for _ in range(connections)
            ]
            await asyncio.sleep(3.0)  # let the flood land before the operator arrives
            served = await operator_request(url)
            held = await asyncio.gather(*flood)
        text = log.read_text(errors="replace")
    accepted = [s for s in held if s is not None]
    return {
        "connections": connections,
        "nofile": nofile,
        "hold_s": hold,
        "accepted": len(accepted),
        "open_s": {
            "median": statistics.median(accepted) if accepted else None,
            "max": max(accepted, default=None),
        },
        "closed_within_1s": sum(1 for s in accepted if s < 1.0),
        "open_at_hold": sum(1 for s in accepted if s >= hold),
        "operator": served,
        "log_tracebacks": text.count("Traceback"),
        "log_lines": len(text.splitlines()),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench.console", description=__doc__)
    ap.add_argument("--connections", type=int, default=400)
    ap.add_argument("--nofile", type=int, default=256, help="the console's open-file limit")
    ap.add_argument("--hold", type=float, default=30.0, help="longest wait per slow client (s)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    r = asyncio.run(_run(args.connections, args.nofile, args.hold))
    if args.json:
        print(json.dumps(r, indent=1))
        return 0
    o, op = r["open_s"], r["operator"]
    print(f"{r['connections']} slow-header connections, console at {r['nofile']} open files")
    print(f"  accepted {r['accepted']}; open p50 {o['median']:.1f} s, max {o['max']:.1f} s")
    held = f"still open after {r['hold_s']:.0f} s: {r['open_at_hold']}"
    print(f"  closed within 1 s: {r['closed_within_1s']}; {held}")
    verdict = "served" if op["served"] else f"NOT served ({op.get('error', op.get('status'))})"
    print(f"  the operator's request: {verdict} in {op['seconds']:.2f} s")
    print(f"  console log: {r['log_lines']} lines, {r['log_tracebacks']} tracebacks")
    return 0 if op["served"] and not r["log_tracebacks"] else 1


if __name__ == "__main__":
    sys.exit(main())
