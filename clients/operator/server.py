"""``cyborg operator``: the remote operator's console, a local web page served by aiohttp.

One process per operator: it joins the rig's bus (usually through a zenoh router), folds
the telemetry with :class:`~clients.watch.RigWatch` and serves a page on 127.0.0.1. The
page gets the state as JSON and the live view as binary frames over one WebSocket. Only
the holder of the launch secret, on the console's own origin, gets in (see :mod:`.guard`).

Frames are latest-wins end to end: each page has one slot that a new frame overwrites,
and the next frame leaves only when the page has acknowledged the last one. A slow
browser or link sees fewer, fresh frames; no queue grows anywhere. The frame subscription
itself exists only while a page is open, so the daemon grabs frames only when watched.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import mimetypes
import struct
import time
from collections import OrderedDict
from pathlib import Path
from typing import Any

from aiohttp import WSMsgType, web

from cyborg.protocol.aims import EXCLUSIONS, KINDS
from cyborg.protocol.messages import (
    REQUESTS,
    Ack,
    ArchiveGet,
    ArchiveList,
    StreamRequest,
)

from ..rigclient import LiveFrame, RigClient, RigError, RigRefusedError
from ..watch import RigWatch
from .guard import ASSETS, INDEX, Guard

__all__ = ["Operator"]

STATIC = Path(__file__).parent / "static"
REPORT_CSP = (
    "default-src 'none'; img-src 'self' data:; style-src 'unsafe-inline'; "
    "frame-ancestors 'none'; base-uri 'none'; form-action 'none'"
)
"""An archived HTML page (report.html) may show its embedded images and style; nothing
in it runs."""
CACHE_BYTES = 64 << 20
"""Archived products are immutable once listed; keep the recent ones near the page."""


class _Page:
    """One open page: a latest-frame slot and a flag for new state."""

    def __init__(self, ws: web.WebSocketResponse) -> None:
        self.ws = ws
        self.frame: LiveFrame | None = None
        self.acked = True
        self.wake = asyncio.Event()


class Operator:
    def __init__(self, client: RigClient, guard: Guard) -> None:
        self.client = client
        self.guard = guard
        self.watch = RigWatch(client)
        self._pages: set[_Page] = set()
        self._frames: Any = None  # the zenoh subscriber while a page is open
        self._view_key: str | None = None
        """The live view the console shows: None, the rig's default; else a stream."""
        self._cache: OrderedDict[str, bytes] = OrderedDict()
        self._cached = 0

    def app(self) -> web.Application:
        app = web.Application(client_max_size=1 << 16)
        self.guard.install(app)
        app.add_routes(
            [
                web.get("/", self._index, name=INDEX),
                web.static("/static", STATIC, name=ASSETS),
                web.get("/ws", self._socket),
                web.get("/api/commands", self._commands),
                web.get("/api/aims", self._aims),
                web.post("/api/view", self._view),
                web.post("/api/{verb:.+}", self._command),
                web.get("/api/archive", self._archive),
                web.get("/api/archive/{session}", self._archive),
                web.get("/archive/{session}/{product:.+}", self._product),
            ]
        )
        return app

    # -- page and state ------------------------------------------------------------------

    async def _index(self, request: web.Request) -> web.FileResponse:
        return web.FileResponse(STATIC / "index.html")

    def state(self) -> dict[str, Any]:
        v = self.watch.view
        body = {
            "me": self.client.name,
            "rig": self.client.keys.rig,
            "alive": v.alive,
            "ptu": v.ptu.to_body() if v.ptu else None,
            "status": v.status.to_body() if v.status else None,
            "progress": v.progress.to_body() | {"eta": v.eta()} if v.progress else None,
            "result": v.result.to_body() if v.result else None,
            "chips": [
                {
                    "rank": c.rank,
                    "station": c.station,
                    "product": c.product,
                    "pan": c.pan,
                    "tilt": c.tilt,
                }
                for c in sorted(v.chips.values(), key=lambda c: c.rank)
            ],
            "log": [{"at": e.at, "level": e.level, "text": e.text} for e in list(v.log)[-30:]],
        }
        return {"type": "state", **body}

    async def _socket(self, request: web.Request) -> web.WebSocketResponse:
        # No per-message compression: JPEG does not shrink, and it would cost a core.
        ws = web.WebSocketResponse(heartbeat=20.0, max_msg_size=1 << 16, compress=False)
        await ws.prepare(request)
        page = _Page(ws)
        self._pages.add(page)
        if self._frames is None:
            self._frames = self.client.frame_subscriber(self._on_frame, self._view_key)
        sender = asyncio.create_task(self._send(page))
        try:
            async for msg in ws:
                if msg.type != WSMsgType.TEXT:
                    continue
                with contextlib.suppress(ValueError, TypeError):
                    if json.loads(msg.data).get("type") == "ack":
                        page.acked = True
                        page.wake.set()
        finally:
            sender.cancel()
            self._pages.discard(page)
            if not self._pages and self._frames is not None:
                with contextlib.suppress(Exception):
                    self._frames.undeclare()
                self._frames = None
        return ws

    async def _view(self, request: web.Request) -> web.Response:
        """``POST /api/view`` {fps, width, quality}, or {} for the rig's own live view: the
        console's live view, fitted to its link (every page of this console shares it)."""
        try:
            body = await request.json()
            if not isinstance(body, dict):
                raise ValueError("the body must be a JSON object")
            key = None
            if body:
                req = StreamRequest.from_body(body)
                key = await self.client.stream(req.fps, req.width, req.quality)
        except (ValueError, RigError) as exc:
            return web.json_response({"ok": False, "result": "ERROR", "detail": str(exc)})
        self._view_key = key
        if self._frames is not None:
            with contextlib.suppress(Exception):
                self._frames.undeclare()
            self._frames = self.client.frame_subscriber(self._on_frame, key)
        detail = f"live view: {key.rsplit('/', 1)[-1]}" if key else "live view: the rig's own"
        return web.json_response({"ok": True, "result": "OK", "detail": detail})

    def _on_frame(self, frame: LiveFrame) -> None:
        for page in self._pages:
            page.frame = frame  # latest wins: an unsent frame is simply replaced
            page.wake.set()

    async def _send(self, page: _Page) -> None:
        seen = -1
        with contextlib.suppress(ConnectionError, RuntimeError):
            while not page.ws.closed:
                if self.watch.version != seen:
                    seen = self.watch.version
                    await page.ws.send_str(json.dumps(self.state()))
                if page.frame is not None and page.acked:
                    frame, page.frame, page.acked = page.frame, None, False
                    await page.ws.send_bytes(_pack(frame))
                page.wake.clear()
                with contextlib.suppress(TimeoutError):
                    async with asyncio.timeout(0.25):  # state changes are polled
                        await page.wake.wait()

    async def changes(self) -> None:
        """Wake every page when the rig's state changes."""
        async for _ in self.watch.changes():
            for page in self._pages:
                page.wake.set()

    # -- commands ------------------------------------------------------------------------

    async def _commands(self, request: web.Request) -> web.Response:
        """``GET /api/commands``: the commands ``POST /api/<verb>`` takes, from the protocol's
        registry, and what each needs ({verb: {moves, read_only}}); the page reads it."""
        return web.json_response(
            {
                verb: {"moves": kind.MOVES, "read_only": kind.READ_ONLY}
                for verb, kind in REQUESTS.items()
                if kind.REPLY is Ack
            }
        )

    async def _aims(self, request: web.Request) -> web.Response:
        """``GET /api/aims``: the aims of study a survey may ask for (``protocol.aims``), each
        with what it means ({kinds: {name: meaning}, exclusions: {...}}); the page lists them."""
        return web.json_response({"kinds": KINDS, "exclusions": EXCLUSIONS})

    async def _command(self, request: web.Request) -> web.Response:
        """``POST /api/<verb>`` with the request's fields as a JSON object: every command the
        rig answers with an ack (protocol.messages.REQUESTS), checked by its own class."""
        verb = request.match_info["verb"]
        kind = REQUESTS.get(verb)
        if kind is None or kind.REPLY is not Ack:
            return web.json_response({"ok": False, "error": f"no command {verb!r}"}, status=404)
        try:
            body = await request.json() if request.can_read_body else {}
            if not isinstance(body, dict):
                raise ValueError("the body must be a JSON object")
            msg = kind.from_body(body)
        except ValueError as exc:  # bad JSON, a wrong type, a missing field, out of range
            self.watch.note("refused", f"{verb}: bad request: {exc}")
            return web.json_response(
                {"ok": False, "result": "ERROR", "detail": f"bad request: {exc}"}
            )
        outcome = await self.watch.act(
            verb,
            lambda: self.client.command(msg),
            motion=kind.MOVES,
            take_hint="press Take to take it over",
        )
        return web.json_response(
            {"ok": outcome.ok, "result": outcome.result, "detail": outcome.detail}
        )

    # -- archive -------------------------------------------------------------------------

    async def _archive(self, request: web.Request) -> web.Response:
        session = request.match_info.get("session", "")
        try:
            listing = await self.client.command(ArchiveList(session))
        except RigError as exc:
            return web.json_response({"ok": False, "error": str(exc)}, status=502)
        return web.json_response({"ok": True, "session": session, "items": list(listing.items)})

    async def _product(self, request: web.Request) -> web.Response:
        session, product = request.match_info["session"], request.match_info["product"]
        key = f"{session}/{product}"
        data = self._cache.get(key)
        if data is None:
            try:
                reply = await self.client.command(ArchiveGet(session, product))
            except RigRefusedError as exc:
                raise web.HTTPNotFound(text=exc.ack.detail) from None
            except RigError as exc:
                raise web.HTTPBadGateway(text=str(exc)) from None
            data = reply.data
            if not product.endswith(".json"):  # manifests change; images do not
                self._remember(key, data)
        kind = mimetypes.guess_type(product)[0] or "application/octet-stream"
        response = web.Response(body=data, content_type=kind)
        if kind == "text/html":  # the session report: its own style and images, no script
            response.headers["Content-Security-Policy"] = REPORT_CSP
        return response

    def _remember(self, key: str, data: bytes) -> None:
        self._cache[key] = data
        self._cached += len(data)
        while self._cached > CACHE_BYTES and self._cache:
            _, old = self._cache.popitem(last=False)
            self._cached -= len(old)


def _pack(frame: LiveFrame) -> bytes:
    """A frame for the page: a 4-byte length, a JSON header, then the JPEG."""
    h = frame.header
    header = json.dumps(
        {
            "seq": h.seq,
            "width": h.width,
            "height": h.height,
            "pan": h.pan,
            "tilt": h.tilt,
            "ts_ms": frame.ts / 1e6,
            "relay_ms": time.time() * 1e3,
        }
    ).encode()
    return struct.pack(">I", len(header)) + header + frame.jpeg
