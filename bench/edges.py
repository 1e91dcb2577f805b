"""Edge benchmark: how ``cyborg survey`` ends when its rig vanishes or its user presses Ctrl-C.

``cyborgd`` runs as a real process (PTU emulator on a pty, simulated camera), and
``cyborg survey`` as another, linked straight to it over loopback TCP (the wearable's own
link). Once the survey reports its first tile, the benchmark either SIGKILLs the daemon
(a crash, a pulled battery) or SIGSTOPs it (a silent link: no TCP reset, only zenoh's lease
can tell) and times how long the script takes to exit, or sends the script SIGINT (Ctrl-C)
and reads what the rig is left doing and who holds its control.

Usage: ``python -m bench.edges [--runs 3] [--cli-timeout 300] [--json]``.
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
from typing import Any

from cyborg.clients.launch import Daemon, free_port, simulated_config, spawn
from cyborg.clients.rigclient import RigClient
from cyborg.protocol.messages import SurveyStatus
from cyborg.protocol.transport import Transport

RIG = "edgebench"


async def _rig(tmp: Path, run: int) -> tuple[Daemon, str]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    config = tmp / f"edges{run}.toml"
    config.write_text(simulated_config(RIG, tmp / "archive", listen=[endpoint], time_scale=2))
    return await spawn(["--config", str(config)], tmp / "cyborgd.log"), endpoint


async def _survey(endpoint: str, timeout: float) -> asyncio.subprocess.Process:
    """``cyborg survey`` as a script runs it, returned once its first tile is reported."""
    proc = await asyncio.create_subprocess_exec(
        *(sys.executable, "-m", "cyborg.clients", "survey", "--rows", "2", "--cols", "3"),
        *("--rig", RIG, "--connect", endpoint, "--name", "script"),
        *("--timeout", f"{timeout:g}", "--json"),
        stdout=asyncio.subprocess.PIPE,
        stderr=asyncio.subprocess.PIPE,
    )
    while b"tiles 1/" not in await proc.stderr.readline():
        pass
    return proc


async def _finish(proc: asyncio.subprocess.Process, since: float) -> dict[str, Any]:
    _, rest = await proc.communicate()
    lines = rest.decode(errors="replace").splitlines()
    said = [line for line in lines if ": tiles " not in line]
    return {
        "seconds": time.perf_counter() - since,
        "status": proc.returncode,
        "stderr_lines": len(said),
        "traceback": any("Traceback" in line for line in said),
        "last": said[-1] if said else "",
    }


async def _vanished(tmp: Path, run: int, timeout: float, how: signal.Signals) -> dict[str, Any]:
    daemon, endpoint = await _rig(tmp, run)
    try:
        proc = await _survey(endpoint, timeout)
        t0 = time.perf_counter()
        daemon.proc.send_signal(how)
        return await _finish(proc, t0)
    finally:
        with contextlib.suppress(ProcessLookupError):
            daemon.proc.send_signal(signal.SIGCONT)
        await daemon.stop()


async def _interrupted(tmp: Path, run: int, timeout: float) -> dict[str, Any]:
    daemon, endpoint = await _rig(tmp, run)
    try:
        proc = await _survey(endpoint, timeout)
        t0 = time.perf_counter()
        proc.send_signal(signal.SIGINT)
        report = await _finish(proc, t0)
        with RigClient.open(Transport("client", connect=(endpoint,)), RIG, "bench") as client:
            status = await client.command(SurveyStatus())
        return report | {"rig_state": status.state, "controller": status.controller}
    finally:
        await daemon.stop()


async def _run(runs: int, timeout: float) -> dict[str, list[dict[str, Any]]]:
    with tempfile.TemporaryDirectory(prefix="bench-edges-") as tmp:
        report = {
            how: [await _vanished(Path(tmp), n, timeout, sig) for n in range(runs)]
            for how, sig in (("killed", signal.SIGKILL), ("frozen", signal.SIGSTOP))
        }
        report["interrupted"] = [await _interrupted(Path(tmp), n, timeout) for n in range(runs)]
    return report


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="bench.edges", description=__doc__)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--cli-timeout", type=float, default=300.0, help="cyborg survey --timeout")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    report = asyncio.run(_run(args.runs, args.cli_timeout))
    if args.json:
        print(json.dumps(report, indent=1))
        return 0
    for case, rows in report.items():
        times = [r["seconds"] for r in rows]
        print(
            f"{case}: exit in median {statistics.median(times):.2f} s, max {max(times):.2f} s; "
            f"status {sorted({r['status'] for r in rows})}; "
            f"stderr lines {sorted({r['stderr_lines'] for r in rows})}; "
            f"traceback {sum(r['traceback'] for r in rows)}/{len(rows)}"
        )
        for r in rows:
            rig = (
                f"  rig {r['rig_state']}, control {r['controller'] or 'nobody'}"
                if "rig_state" in r
                else ""
            )
            print(f"  {r['seconds']:7.2f} s  status {r['status']}  {r['last']!r}{rig}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
