"""``cyborg operator``'s process: the bus session, the page server, clean shutdown."""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import signal

from aiohttp import web

from ..link import transport
from ..rigclient import RigClient
from .guard import Guard, allowed_hosts
from .limits import IDLE_TIMEOUT_S, Doors, DoorsSite
from .server import Operator

__all__ = ["run_operator"]


def _public_hosts(args: argparse.Namespace) -> list[str]:
    values = getattr(args, "public_host", None) or []
    return [name.strip() for value in values for name in value.split(",") if name.strip()]


async def _serve(args: argparse.Namespace) -> int:
    public = _public_hosts(args)
    try:
        allowed_hosts(args.host, args.port, public)
    except ValueError as exc:
        print(f"cyborg operator: --public-host: {exc}")
        return 2
    link = transport(args, "peer")
    with RigClient.open(link, args.rig, args.name) as client:
        guard = Guard()
        operator = Operator(client, guard)
        doors = Doors()
        app = operator.app()
        doors.install(app)
        runner = web.AppRunner(app, access_log=None, keepalive_timeout=IDLE_TIMEOUT_S)
        await runner.setup()
        site = DoorsSite(runner, args.host, args.port, doors)
        try:
            await site.start()
        except OSError as exc:
            await runner.cleanup()
            print(f"cyborg operator: cannot listen on {args.host}:{args.port}: {exc.strerror}")
            return 1
        host, port = site.addresses[0]
        bound = f"[{host}]:{port}" if ":" in host else f"{host}:{port}"
        guard.bind(args.host, port, [*public, bound])
        print(
            f"cyborg operator: {guard.url(host, port)}  (rig {args.rig} via "
            f"{', '.join(link.connect)}; Ctrl-C to stop)\n"
            "  keep this URL private: whoever opens it can drive the rig",
            flush=True,
        )
        for name in public:
            print(f"  through the proxy: https://{name}/?token={guard.token}", flush=True)
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        tasks = [asyncio.create_task(operator.watch.run()), asyncio.create_task(operator.changes())]
        await stop.wait()
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)
        with contextlib.suppress(Exception):
            await runner.cleanup()
    return 0


def run_operator(args: argparse.Namespace) -> int:
    return asyncio.run(_serve(args))
