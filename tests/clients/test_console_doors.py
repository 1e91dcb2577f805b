"""The console's doors on a real loopback socket: a peer over its cap loses its oldest idle
connection, never one in a request, and is refused when all of them are busy."""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Awaitable, Callable

import pytest
from aiohttp import web

from cyborg.clients.operator.limits import Doors, DoorsSite

pytestmark = pytest.mark.timeout(60)


class _App:
    """``/wait`` answers when the test says so (a request in progress); ``/`` at once."""

    def __init__(self) -> None:
        self.release = asyncio.Event()
        self.waiting = asyncio.Event()

    async def wait(self, request: web.Request) -> web.Response:
        self.waiting.set()
        await self.release.wait()
        return web.Response(text="late")

    async def now(self, request: web.Request) -> web.Response:
        return web.Response(text="now")


@pytest.fixture
async def console() -> AsyncIterator[Callable[[int], Awaitable[tuple[_App, int]]]]:
    """Factory: an app behind :class:`Doors` with a given cap per peer, on a free port;
    connections are never closed for idleness here, only by the doors."""
    runners: list[web.AppRunner] = []

    async def start(per_peer: int) -> tuple[_App, int]:
        handlers = _App()
        app = web.Application()
        app.add_routes([web.get("/wait", handlers.wait), web.get("/", handlers.now)])
        doors = Doors(per_peer)
        doors.install(app)
        runner = web.AppRunner(app, access_log=None, keepalive_timeout=3600)
        await runner.setup()
        runners.append(runner)
        site = DoorsSite(runner, "127.0.0.1", 0, doors)
        await site.start()
        return handlers, site.addresses[0][1]

    yield start
    for runner in runners:
        await runner.cleanup()


async def _connect(port: int) -> tuple[asyncio.StreamReader, asyncio.StreamWriter]:
    return await asyncio.open_connection("127.0.0.1", port)


async def _get(conn: tuple[asyncio.StreamReader, asyncio.StreamWriter], path: str) -> bytes:
    reader, writer = conn
    writer.write(f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode())
    await writer.drain()
    return await reader.readuntil(b"\r\n\r\n")


async def _closed(conn: tuple[asyncio.StreamReader, asyncio.StreamWriter]) -> bool:
    """Whether the console closed it (waits for the end of the stream)."""
    try:
        return await conn[0].read() == b""
    except ConnectionResetError:
        return True


async def test_over_the_cap_the_oldest_idle_connection_goes_not_a_busy_one(console) -> None:
    app, port = await console(2)
    busy = await _connect(port)
    busy[1].write(b"GET /wait HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
    await app.waiting.wait()
    idle = await _connect(port)
    newcomer = await _connect(port)
    assert await _closed(idle)
    assert (await _get(newcomer, "/")).startswith(b"HTTP/1.1 200")
    app.release.set()
    assert (await busy[0].readuntil(b"\r\n\r\n")).startswith(b"HTTP/1.1 200")
    for _, writer in (busy, idle, newcomer):
        writer.close()


async def test_a_peer_whose_connections_are_all_busy_is_refused_more(console) -> None:
    app, port = await console(1)
    busy = await _connect(port)
    busy[1].write(b"GET /wait HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
    await app.waiting.wait()
    refused = await _connect(port)
    assert await _closed(refused)
    app.release.set()
    assert (await busy[0].readuntil(b"\r\n\r\n")).startswith(b"HTTP/1.1 200")
    for _, writer in (busy, refused):
        writer.close()
