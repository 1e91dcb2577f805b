"""How many connections the console keeps, and for how long: no slow or idle client, nor a
crowd of them, keeps the operator out.

- **Header and idle timeout.** aiohttp's own ``keepalive_timeout`` (:data:`IDLE_TIMEOUT_S`)
  runs from the moment a connection opens and again after each response, and a trickle of
  header bytes does not reset it: a connection that has not finished a request header in
  that time, or sits idle that long between requests, is closed.
- **Caps.** One peer address may hold :data:`PER_PEER` connections, and all together stay
  :data:`RESERVE` below the process's open-file limit (and under :data:`MOST`). A
  connection over a cap closes its peer's (or anyone's) oldest connection that is not in a
  request, so a legitimate request still gets in; when every one is busy, it is refused.
- **Accept errors** (out of file descriptors) are one log line and a short pause.

Hand-written because neither library has it: aiohttp has no connection caps, and asyncio's
accept loop logs a traceback for every refused accept (and stacks up its retries). So
:class:`Doors` accepts itself and hands each admitted socket to aiohttp's server with
``loop.connect_accepted_socket``.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import logging
import resource
import socket
from collections.abc import Awaitable, Callable
from dataclasses import dataclass

from aiohttp import web

from .guard import Notes

__all__ = ["IDLE_TIMEOUT_S", "MOST", "PER_PEER", "RESERVE", "Doors", "DoorsSite"]

_LOGGER = logging.getLogger(__name__)

IDLE_TIMEOUT_S = 10.0
"""Longest wait for a request header, and longest idle keep-alive (``keepalive_timeout``)."""
PER_PEER = 32
"""Connections one address may hold: a browser opens 6 per host plus its WebSockets, and a
reverse proxy in front is one address for every page it serves."""
RESERVE = 32
"""Open files kept free of connections for the bus session, the page's files and the log."""
MOST = 256
"""Connections in all, whatever the open-file limit: one operator's console."""
ACCEPT_RETRY_S = 0.5
"""Pause after an accept that failed for want of file descriptors."""
_OUT_OF_FILES = (errno.EMFILE, errno.ENFILE, errno.ENOBUFS, errno.ENOMEM)
_Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


@dataclass
class _Connection:
    transport: asyncio.BaseTransport
    peer: str
    busy: int = 0
    """Requests being handled on it (a WebSocket counts while it is open)."""


def _open_files() -> int:
    soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
    return MOST + RESERVE if soft == resource.RLIM_INFINITY else soft


class Doors:
    """Admission for one console: counts, caps and the accept loop's errors."""

    def __init__(self, per_peer: int = PER_PEER) -> None:
        self.per_peer = per_peer
        self._open: dict[asyncio.BaseTransport, _Connection] = {}  # oldest first
        self._note = Notes(_LOGGER)

    def install(self, app: web.Application) -> None:
        """Mark connections busy while a request runs (outermost middleware)."""
        app.middlewares.insert(0, self._busy)

    def most(self) -> int:
        """Connections allowed in all, read afresh: the limit may change while we run."""
        return max(1, min(MOST, _open_files() - RESERVE))

    def admit(self, peer: str) -> bool:
        """Make room for one more connection from ``peer``: close the oldest idle one over a
        cap; False if every one in the way is busy."""
        self._open = {t: c for t, c in self._open.items() if not t.is_closing()}
        mine = [c for c in self._open.values() if c.peer == peer]
        if len(mine) >= self.per_peer:
            crowd, why = mine, f"a connection from {peer}: {len(mine)} open, its cap"
        elif len(self._open) >= self.most():
            crowd, why = list(self._open.values()), f"a connection: {len(self._open)} open"
        else:
            return True
        idle = next((c for c in crowd if not c.busy), None)
        if idle is None:
            self._note("busy", f"{why}, all of them in requests")
            return False
        self._note("evict", f"{why}; closed the oldest idle one (from {idle.peer})")
        idle.transport.close()
        del self._open[idle.transport]
        return True

    async def accept(self, listener: socket.socket, server: web.Server) -> None:
        """Accept on ``listener`` until cancelled, handing admitted sockets to ``server``."""
        loop = asyncio.get_running_loop()
        while True:
            try:
                conn, address = await loop.sock_accept(listener)
            except OSError as exc:
                if exc.errno not in _OUT_OF_FILES:
                    _LOGGER.debug("accept: %s", exc)  # e.g. a peer that gave up at once
                    continue
                self._note("accept", f"a connection: out of file descriptors ({exc.strerror})")
                await asyncio.sleep(ACCEPT_RETRY_S)
                continue
            peer = str(address[0])
            if not self.admit(peer):
                conn.close()
                continue
            try:
                transport, _ = await loop.connect_accepted_socket(server, conn)
            except OSError as exc:
                _LOGGER.debug("a connection from %s failed at once: %s", peer, exc)
                conn.close()
                continue
            self._open[transport] = _Connection(transport, peer)

    @web.middleware
    async def _busy(self, request: web.Request, handler: _Handler) -> web.StreamResponse:
        conn = self._open.get(request.transport) if request.transport else None
        if conn is None:
            return await handler(request)
        conn.busy += 1
        try:
            return await handler(request)
        finally:
            conn.busy -= 1


class DoorsSite(web.BaseSite):
    """A TCP site whose connections pass :class:`Doors` (aiohttp's TCPSite accepts through
    asyncio, which has no hook for that)."""

    def __init__(self, runner: web.BaseRunner, host: str, port: int, doors: Doors) -> None:
        super().__init__(runner)
        self._host, self._port, self._doors = host, port, doors
        self._listeners: list[socket.socket] = []
        self._tasks: list[asyncio.Task[None]] = []

    @property
    def name(self) -> str:
        return f"http://{self._host}:{self._port}"

    @property
    def addresses(self) -> list[tuple[str, int]]:
        """(host, port) of each listening socket."""
        return [sock.getsockname()[:2] for sock in self._listeners]

    async def start(self) -> None:
        await super().start()
        server = self._runner.server
        assert server is not None  # the runner is set up
        loop = asyncio.get_running_loop()
        infos = await loop.getaddrinfo(
            self._host, self._port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE
        )
        port = self._port
        for family, kind, proto, _, address in dict.fromkeys(infos):
            sock = socket.socket(family, kind, proto)
            self._listeners.append(sock)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            if family == socket.AF_INET6:
                sock.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
            sock.bind((address[0], port, *address[2:]))
            port = sock.getsockname()[1]  # port 0: every address on the one the first got
            sock.listen(self._backlog)
            sock.setblocking(False)
        self._tasks = [
            asyncio.create_task(self._doors.accept(sock, server), name="cyborg.operator.accept")
            for sock in self._listeners
        ]

    async def stop(self) -> None:
        for task in self._tasks:
            task.cancel()
        for task in self._tasks:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        for sock in self._listeners:
            sock.close()
        await super().stop()
