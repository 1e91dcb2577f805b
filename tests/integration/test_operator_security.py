"""The operator console against strangers and hostile pages, all real: ``cyborgd`` behind a
router, ``cyborg operator`` as a process, HTTP and WebSockets over loopback, and headless
Chromium visiting a hostile page served from another origin. Every refusal is also checked
from the rig's side: the head did not move and nobody took control."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from http.cookies import SimpleCookie
from pathlib import Path
from typing import Any

import aiohttp
import pytest
from aiohttp import web

from bench.browser import MISSING, Browser, chromium
from cyborg.clients.launch import operator as launch_operator
from cyborg.clients.operator.guard import Guard, allowed_hosts
from cyborg.clients.operator.server import Operator
from cyborg.clients.rigclient import RigClient
from cyborg.protocol.messages import PtuState

pytestmark = pytest.mark.timeout(120)
needs_chromium = pytest.mark.skipif(bool(MISSING), reason=MISSING or "")

GOTO = {"pan": 20.0, "tilt": 10.0}
"""What every hostile request asks: a motion that would also take control if obeyed."""


class _Console:
    """The printed URL taken apart, and the console's log."""

    def __init__(self, url: str, log: Path) -> None:
        self.url = url
        self.log = log
        self.base, _, self.token = url.partition("/?token=")
        self.port = int(self.base.rsplit(":", 1)[1])
        self.host = self.base.removeprefix("http://")


@pytest.fixture
async def console(router: str, tmp_path: Path) -> AsyncIterator[_Console]:
    """``cyborg operator`` on a free port, as the existing operator tests start it."""
    log = tmp_path / "operator.log"
    async with launch_operator(router, "itest", "remote-op", log) as url:
        yield _Console(url, log)
    assert b"Traceback" not in (tmp_path / "operator.log").read_bytes()


@pytest.fixture
async def http() -> AsyncIterator[aiohttp.ClientSession]:
    """A client that keeps no cookies: each request says exactly what it carries."""
    async with aiohttp.ClientSession(cookie_jar=aiohttp.DummyCookieJar()) as session:
        yield session


@pytest.fixture
def browser() -> AsyncIterator[Browser]:
    with chromium() as b:
        yield b


async def _sign_in(http: aiohttp.ClientSession, console: _Console) -> dict[str, str]:
    """Visit the printed URL as a browser would; the Cookie header it earns."""
    async with http.get(console.url, allow_redirects=False) as r:
        assert r.status == 303 and r.headers["Location"] == "/"
        raw = r.headers["Set-Cookie"]
    morsel = next(iter(SimpleCookie(raw).values()))
    assert morsel.value == console.token
    assert morsel["httponly"] and morsel["samesite"] == "Strict" and morsel["path"] == "/"
    return {"Cookie": f"{morsel.key}={morsel.value}"}


async def _raw(port: int, *lines: str, body: bytes = b"") -> tuple[int, bytes]:
    """One request written by hand (a Host no HTTP library would send); status and body."""
    reader, writer = await asyncio.open_connection("127.0.0.1", port)
    try:
        head = "\r\n".join([*lines, f"Content-Length: {len(body)}", "", ""])
        writer.write(head.encode() + body)
        await writer.drain()
        status, *headers = (await reader.readuntil(b"\r\n\r\n")).decode().split("\r\n")
        length = next(
            (int(h.split(":")[1]) for h in headers if h.lower().startswith("content-length:")), 0
        )
        return int(status.split()[1]), await reader.readexactly(length)
    finally:
        writer.close()
        await writer.wait_closed()


async def _pose(client: RigClient) -> PtuState:
    """A PTU state published after this call: any command acknowledged before is in it."""
    states = client.subscribe(client.keys.ptu_state, PtuState)
    async with asyncio.timeout(20):
        while True:
            state = await states.get()
            if not state.moving:
                return state


async def test_strangers_without_the_secret_get_nothing(
    daemon, console: _Console, http: aiohttp.ClientSession, client: RigClient
) -> None:
    await client.wait_alive()
    before = await _pose(client)
    for cookie in ({}, {"Cookie": f"cyborg_operator_{console.port}=wrong"}):
        async with http.post(f"{console.base}/api/ptu/goto", json=GOTO, headers=cookie) as r:
            assert r.status == 401 and (await r.json())["ok"] is False
        for path in ("/api/archive", "/api/archive/s1", "/archive/s1/st01/mosaic.png"):
            async with http.get(console.base + path, headers=cookie) as r:
                assert r.status == 401, path
        with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
            await http.ws_connect(f"{console.base}/ws", headers=cookie)
        assert refused.value.status == 401
        async with http.get(f"{console.base}/", headers=cookie) as r:
            assert r.status == 401 and "Open the URL the operator printed" in await r.text()
    async with http.get(f"{console.base}/?token=not-the-token", allow_redirects=False) as r:
        assert r.status == 401 and "Set-Cookie" not in r.headers
    async with http.get(f"{console.base}/static/app.js") as r:  # code, no data
        assert r.status == 200
    after = await _pose(client)
    assert after.controller == "" and (after.pan, after.tilt) == (before.pan, before.tilt)


async def test_cross_site_requests_and_rebinding_are_refused(
    daemon, console: _Console, http: aiohttp.ClientSession, client: RigClient
) -> None:
    await client.wait_alive()
    before = await _pose(client)
    cookie = await _sign_in(http, console)
    sent = f"Cookie: {cookie['Cookie']}"
    api = f"{console.base}/api/ptu/goto"
    own = {**cookie, "Origin": console.base}

    # A form or a simple fetch() can only send text/plain (or form types), never JSON.
    body = json.dumps(GOTO)
    plain = {**own, "Content-Type": "text/plain"}
    async with http.post(api, data=body, headers=plain) as r:
        assert r.status == 415
    # Another origin, even on this host with the cookie (127.0.0.1 is one "site").
    for origin in ("http://127.0.0.1:1", "http://evil.example", "null"):
        async with http.post(api, json=GOTO, headers={**cookie, "Origin": origin}) as r:
            assert r.status == 403, origin
        with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
            await http.ws_connect(f"{console.base}/ws", headers={**cookie, "Origin": origin})
        assert refused.value.status == 403
    async with http.get(
        f"{console.base}/api/archive", headers={**cookie, "Sec-Fetch-Site": "same-site"}
    ) as r:
        assert r.status == 403
    # DNS rebinding: a hostile name resolving to 127.0.0.1 reaches the port, not the console.
    rebound = f"Host: evil.example:{console.port}"
    for path in ("/", "/api/archive", f"/?token={console.token}"):
        status, _ = await _raw(console.port, f"GET {path} HTTP/1.1", rebound, sent)
        assert status == 403, path
    status, _ = await _raw(
        console.port,
        "POST /api/ptu/goto HTTP/1.1",
        rebound,
        sent,
        "Content-Type: application/json",
        body=body.encode(),
    )
    assert status == 403

    after = await _pose(client)
    assert after.controller == "" and (after.pan, after.tilt) == (before.pan, before.tilt)

    # The same requests with the console's own Host and Origin work.
    async with http.post(f"{console.base}/api/ptu/halt", json={}, headers=own) as r:
        assert r.status == 200 and (await r.json())["ok"] is True
    for host in (console.host, f"localhost:{console.port}"):
        status, page = await _raw(console.port, "GET / HTTP/1.1", f"Host: {host}", sent)
        assert status == 200 and b"Cyborg operator" in page, host
    async with http.ws_connect(f"{console.base}/ws", headers=own) as ws:
        first = await ws.receive_json(timeout=10)
        assert first["type"] == "state" and first["me"] == "remote-op"
    async with http.get(f"{console.base}/", headers=cookie) as r:
        assert r.status == 200
        assert r.headers["X-Frame-Options"] == "DENY"
        assert r.headers["X-Content-Type-Options"] == "nosniff"
        assert r.headers["Referrer-Policy"] == "no-referrer"
        assert "default-src 'self'" in r.headers["Content-Security-Policy"]
        assert "frame-ancestors 'none'" in r.headers["Content-Security-Policy"]


def test_allowed_hosts_name_the_console_only() -> None:
    hosts = allowed_hosts("127.0.0.1", 8080, ["console.example", "lab.example:8443"])
    guard = Guard("t")
    guard.hosts = hosts
    for ok in ("127.0.0.1:8080", "LOCALHOST:8080", "[::1]:8080", "console.example"):
        assert guard.host_ok(ok), ok
    for ok in ("console.example:443", "lab.example:8443"):
        assert guard.host_ok(ok), ok
    for bad in ("127.0.0.1:8081", "127.0.0.1", "evil.example:8080", "lab.example", "a b", ""):
        assert not guard.host_ok(bad), bad
    assert guard.origin_ok("https://console.example", "console.example")
    assert not guard.origin_ok("http://127.0.0.1:9", "127.0.0.1:8080")
    assert not guard.origin_ok("null", "127.0.0.1:8080")
    with pytest.raises(ValueError):
        allowed_hosts("127.0.0.1", 8080, ["http://console.example/"])


async def test_public_host_behind_a_proxy(client: RigClient) -> None:
    """``--public-host``: through a TLS proxy, Host is the public name and Origin https."""
    guard = Guard()
    runner = web.AppRunner(Operator(client, guard).app())
    await runner.setup()
    site = web.TCPSite(runner, "127.0.0.1", 0)
    await site.start()
    try:
        port = runner.addresses[0][1]
        guard.bind("127.0.0.1", port, ["console.example"])
        cookie = f"Cookie: {guard.cookie}={guard.token}"
        public = "Host: console.example"
        status, _ = await _raw(port, "GET / HTTP/1.1", public, cookie)
        assert status == 200
        status, _ = await _raw(
            port,
            "GET /ws HTTP/1.1",
            public,
            cookie,
            "Origin: https://console.example",
            "Upgrade: websocket",
            "Connection: Upgrade",
            "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==",
            "Sec-WebSocket-Version: 13",
        )
        assert status == 101
        status, _ = await _raw(port, "GET / HTTP/1.1", "Host: other.example", cookie)
        assert status == 403
    finally:
        await runner.cleanup()


HOSTILE = """<!doctype html><title>free kittens</title>
<form id="csrf" method="POST" enctype="text/plain">
<input name='{"pan": 20, "tilt": 10, "x": "' value='"}'></form>
<script>
const C = new URLSearchParams(location.search).get("console");
document.getElementById("csrf").action = C + "/api/ptu/goto";
const tried = {};
const attempt = async (name, f) => {
  try { tried[name] = "got " + (await f()); } catch (e) { tried[name] = "failed: " + e; }
};
const simple = { method: "POST", mode: "no-cors", credentials: "include" };
const json = { method: "POST", credentials: "include",
               headers: { "content-type": "application/json" } };
const tries = {  // each would move the head (or take control) if the console obeyed
  take: () => fetch(C + "/api/control/take", { ...simple, body: "{}" }),
  goto: () => fetch(C + "/api/ptu/goto", { ...simple, body: '{"pan": 20, "tilt": 10}' }),
  json: () => fetch(C + "/api/ptu/goto", { ...json, body: '{"pan": 20, "tilt": 10}' }),
  read: () => fetch(C + "/api/archive", { credentials: "include" }).then((r) => r.text()),
};
(async () => {
  for (const [name, f] of Object.entries(tries)) await attempt(name, f);
  await attempt("socket", () => new Promise((resolve, reject) => {
    const ws = new WebSocket(C.replace("http", "ws") + "/ws");
    ws.onmessage = (ev) => resolve(String(ev.data).slice(0, 60));
    ws.onclose = () => reject(new Error("closed"));
  }));
  window.tried = tried;
})();
</script>"""


TRIES = ("take", "goto", "json", "read")


@pytest.fixture
async def hostile() -> AsyncIterator[str]:
    """A stranger's page on another port of 127.0.0.1: another origin, the same "site"."""

    async def page(request: web.Request) -> web.Response:
        return web.Response(text=HOSTILE, content_type="text/html")

    app = web.Application()
    app.router.add_get("/", page)
    runner = web.AppRunner(app)
    await runner.setup()
    await web.TCPSite(runner, "127.0.0.1", 0).start()
    try:
        yield f"http://127.0.0.1:{runner.addresses[0][1]}/"
    finally:
        await runner.cleanup()


def _errors(browser: Browser) -> list[str]:
    return [e["message"] for e in browser.console() if e["level"] == "SEVERE"]


@needs_chromium
async def test_printed_url_opens_a_clean_console(
    daemon, console: _Console, browser: Browser
) -> None:
    wait = lambda expr: asyncio.to_thread(browser.wait, expr)  # noqa: E731
    await asyncio.to_thread(browser.open, console.url)
    await wait("document.getElementById('rig').textContent === 'rig itest'")  # over the socket
    await wait("window.cyborgStats().frames >= 1")
    await wait(
        "performance.getEntriesByType('resource').some((e) => e.name.endsWith('/api/archive'))"
    )
    await asyncio.to_thread(browser.click, "#halt")
    await wait("document.getElementById('reply').textContent.startsWith('ptu/halt: halted')")
    page = await asyncio.to_thread(
        browser.js,
        "return {href: location.href, cookie: document.cookie, loads: performance"
        ".getEntriesByType('resource').map((e) => [e.name, e.responseStatus])};",
    )
    assert page["href"] == f"{console.base}/"  # the secret left the address bar
    assert page["cookie"] == ""  # HttpOnly: no script can read it
    assert page["loads"] and all(status == 200 for _, status in page["loads"]), page["loads"]
    assert _errors(browser) == []  # no failed load, no CSP violation, no socket error


@needs_chromium
async def test_hostile_page_cannot_drive_the_rig(
    daemon, console: _Console, browser: Browser, hostile: str, client: RigClient
) -> None:
    await client.wait_alive()
    before = await _pose(client)
    # The operator is signed in: the browser holds the cookie, which SameSite=Strict would
    # still send to the console from another port of 127.0.0.1.
    await asyncio.to_thread(browser.open, console.url)
    await asyncio.to_thread(browser.wait, "window.cyborgStats().frames >= 1")

    await asyncio.to_thread(browser.open, f"{hostile}?console={console.base}")
    tried: dict[str, Any] = await asyncio.to_thread(browser.wait, "window.tried")
    # A form POST, the classic JSON CSRF: it navigates to the console's answer.
    await asyncio.to_thread(browser.js, "document.getElementById('csrf').submit();")
    await asyncio.to_thread(browser.wait, f"location.href === '{console.base}/api/ptu/goto'")
    answer = await asyncio.to_thread(browser.wait, "document.body && document.body.innerText")

    after = await _pose(client)
    assert after.controller == "" and (after.pan, after.tilt) == (before.pan, before.tilt)
    assert json.loads(answer)["result"] == "FORBIDDEN"
    # Even the simple no-cors POSTs fail in the page: the refusal is not same-origin readable
    # (Cross-Origin-Resource-Policy), and the console's log shows they arrived and were refused.
    assert all(tried[name].startswith("failed") for name in (*TRIES, "socket")), tried
    log = console.log.read_text()
    assert (
        f"refused POST '/api/control/take': requests from {hostile.rstrip('/')} are refused" in log
    )
