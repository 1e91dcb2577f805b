"""Who may use the operator console: the holder of its launch secret, on its own origin.

The console drives a rig, so a stranger's page in the operator's browser must not reach it.
Every request passes one middleware, in this order:

- **Host** must name the console: the host:port it listens on (plus the 127.0.0.1,
  localhost and [::1] forms when on loopback) or a ``--public-host`` name; else 403. This
  defeats DNS rebinding, where a hostile name resolves to 127.0.0.1.
- **Origin**, when present, must be the console's own (the scheme plus this request's
  Host); else 403. Browsers send it on every POST, fetch() and WebSocket handshake, so a
  page elsewhere (another port of 127.0.0.1 included, which ``SameSite`` treats as the same
  site) can neither post nor open the socket. ``Sec-Fetch-Site``, when present, must say
  same-origin (or none: typed in the address bar), which also stops ``<img>``-style reads.
- **The secret** (``secrets.token_urlsafe``, made at each launch) rides in the printed URL
  once; visiting it sets an HttpOnly, SameSite=Strict cookie and redirects to the clean
  URL. The API, the archive and the WebSocket want the cookie (401 without it); only the
  page's code and style sheet (no data) are served to anyone.
- **POSTs** must be ``application/json`` (415), which no form or simple request can send.

Every response carries a strict Content-Security-Policy and its companions.
"""

from __future__ import annotations

import hmac
import ipaddress
import logging
import re
import secrets
from collections.abc import Awaitable, Callable, Iterable

from aiohttp import hdrs, web

__all__ = ["ASSETS", "COOKIE", "INDEX", "Guard", "Notes", "allowed_hosts"]

_LOGGER = logging.getLogger(__name__)

COOKIE = "cyborg_operator"
"""The cookie's name stem; the listening port is appended so consoles on one host coexist."""

HEADERS = {
    "Content-Security-Policy": "default-src 'self'; script-src 'self'; style-src 'self'; "
    "img-src 'self'; connect-src 'self'; object-src 'none'; base-uri 'none'; "
    "form-action 'none'; frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "X-Frame-Options": "DENY",
    "Cross-Origin-Resource-Policy": "same-origin",
    "Cross-Origin-Opener-Policy": "same-origin",
}
INDEX, ASSETS = "index", "static"
"""Route names: the page (the secret is traded for a cookie there) and its code and style,
which anyone may fetch because they carry no data."""
SIGN_IN = (
    "This is a cyborg operator console. Open the URL the operator printed when it started "
    "(http://HOST:PORT/?token=...): it carries this console's secret."
)

_HOSTPORT = re.compile(r"(\[[0-9a-f:.]+\]|[a-z0-9_.-]+)(?::([0-9]{1,5}))?")
_LOOPBACK_FORMS = ("127.0.0.1", "localhost", "[::1]")
_Handler = Callable[[web.Request], Awaitable[web.StreamResponse]]


def _split(value: str) -> tuple[str, int | None] | None:
    """``host[:port]`` (a Host header or an origin's authority), lower-cased; None if malformed."""
    m = _HOSTPORT.fullmatch(value.strip().lower())
    if m is None:
        return None
    return m[1], int(m[2]) if m[2] else None


def _is_loopback(host: str) -> bool:
    if host in ("localhost", ""):
        return True
    try:
        address = ipaddress.ip_address(host.strip("[]"))
    except ValueError:
        return False
    return address.is_loopback or address.is_unspecified  # 0.0.0.0 listens on loopback too


def allowed_hosts(
    host: str, port: int, public: Iterable[str] = ()
) -> frozenset[tuple[str, int | None]]:
    """The Host values the console answers: its bind address and port (with every loopback
    spelling when it listens there), and each public name (``NAME`` on any port, or
    ``NAME:PORT``). A port of None in the result matches any port."""
    bound = f"[{host}]" if ":" in host else host
    names = {bound.lower()}
    if _is_loopback(host):
        names.update(_LOOPBACK_FORMS)
    allowed: set[tuple[str, int | None]] = {(name, port) for name in names}
    for name in public:
        parsed = _split(name)
        if parsed is None:
            raise ValueError(f"not a host name or host:port: {name!r}")
        allowed.add(parsed)
    return frozenset(allowed)


class Notes:
    """Refusals for the log: the first of each kind is a warning, an attack's flood goes to
    debug (one line each, never a traceback)."""

    def __init__(self, logger: logging.Logger) -> None:
        self._logger = logger
        self._warned: set[str] = set()

    def __call__(self, kind: str, what: str) -> None:
        level = logging.DEBUG if kind in self._warned else logging.WARNING
        self._warned.add(kind)
        self._logger.log(level, "cyborg operator: refused %s", what)


class Guard:
    """The console's checks as one aiohttp middleware; :meth:`bind` once the port is known."""

    def __init__(self, token: str | None = None) -> None:
        self.token = token or secrets.token_urlsafe(32)
        self.cookie = COOKIE
        self.hosts: frozenset[tuple[str, int | None]] = frozenset()  # nothing until bound
        self._note = Notes(_LOGGER)

    def bind(self, host: str, port: int, public: Iterable[str] = ()) -> None:
        """Answer the Host values of ``allowed_hosts(host, port, public)``."""
        self.hosts = allowed_hosts(host, port, public)
        self.cookie = f"{COOKIE}_{port}"

    def url(self, host: str, port: int) -> str:
        """The URL to print: it carries the secret, so only the operator may see it."""
        if host in ("", "0.0.0.0", "::"):
            host = "127.0.0.1"  # a wildcard bind is reached through loopback here
        host = f"[{host}]" if ":" in host else host
        return f"http://{host}:{port}/?token={self.token}"

    def install(self, app: web.Application) -> None:
        app.middlewares.append(self.middleware)
        app.on_response_prepare.append(_secure)

    # -- the checks ----------------------------------------------------------------------

    def host_ok(self, value: str) -> bool:
        parsed = _split(value)
        if parsed is None:
            return False
        name, port = parsed
        # Browsers leave a default port out of Host (and a proxy's port is not ours).
        ports = (None, 80, 443) if port is None else (None, port)
        return any((name, p) in self.hosts for p in ports)

    def origin_ok(self, origin: str, host: str) -> bool:
        """Same origin: an http(s) origin whose authority is this request's (checked) Host."""
        scheme, sep, authority = origin.partition("://")
        return (
            bool(sep)
            and scheme.lower() in ("http", "https")
            and authority.lower() == host.strip().lower()
        )

    def signed_in(self, request: web.Request) -> bool:
        return self._matches(request.cookies.get(self.cookie, ""))

    def _matches(self, given: str) -> bool:
        return hmac.compare_digest(given.encode("utf-8", "replace"), self.token.encode())

    @web.middleware
    async def middleware(self, request: web.Request, handler: _Handler) -> web.StreamResponse:
        hosts = request.headers.getall(hdrs.HOST, [])
        if len(hosts) != 1 or not self.host_ok(hosts[0]):
            return self._refuse(request, 403, "host", "this console does not answer to that Host")
        origin = request.headers.get(hdrs.ORIGIN)
        if origin is not None and not self.origin_ok(origin, hosts[0]):
            return self._refuse(request, 403, "origin", f"requests from {origin} are refused")
        resource = request.match_info.route.resource
        name = resource.name if resource is not None else None
        if name == ASSETS:
            return await handler(request)
        if name == INDEX:
            if "token" in request.query:
                return self._sign_in(request)
            if not self.signed_in(request):
                return _page(401, SIGN_IN)
            return await handler(request)
        if request.headers.get("Sec-Fetch-Site", "same-origin") not in ("same-origin", "none"):
            return self._refuse(request, 403, "site", "cross-site requests are refused")
        if not self.signed_in(request):
            return self._refuse(request, 401, "cookie", "open the URL the operator printed")
        if request.method == hdrs.METH_POST and request.content_type != "application/json":
            return self._refuse(request, 415, "type", "POST bodies must be application/json")
        return await handler(request)

    def _sign_in(self, request: web.Request) -> web.Response:
        """Trade the secret in the URL for a cookie, and take it out of the address bar."""
        if not self._matches(request.query["token"]):
            self._note("token", "a wrong token")
            return _page(401, "That token is not this console's (did it restart?). " + SIGN_IN)
        response = web.Response(status=303, headers={hdrs.LOCATION: "/"})
        response.set_cookie(self.cookie, self.token, path="/", httponly=True, samesite="Strict")
        return response

    def _refuse(self, request: web.Request, status: int, kind: str, why: str) -> web.Response:
        self._note(kind, f"{request.method} {request.path!r}: {why}")
        result = {401: "UNAUTHORIZED", 403: "FORBIDDEN", 415: "UNSUPPORTED"}[status]
        return web.json_response({"ok": False, "result": result, "error": why}, status=status)


def _page(status: int, text: str) -> web.Response:
    return web.Response(status=status, text=text + "\n", headers={hdrs.CACHE_CONTROL: "no-store"})


async def _secure(request: web.Request, response: web.StreamResponse) -> None:
    for name, value in HEADERS.items():
        response.headers.setdefault(name, value)
    if request.path == "/":
        response.headers[hdrs.CACHE_CONTROL] = "no-store"
