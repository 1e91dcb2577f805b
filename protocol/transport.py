"""How a rig's peers find and trust each other: the zenoh settings both sides apply, as data.

Multicast and gossip scouting stay off everywhere: endpoints are always explicit, so a
field network (or two test runs on one machine) never joins the wrong rig by accident.

Links beyond the machine are TLS with mutual authentication (``tls/`` endpoints, a CA,
this side's certificate and key); the certificate's common name is who a peer is, and an
access-control section (:mod:`protocol.access`) says what each name may do. The same
rules hold for every side (the rig, a router, each client), for the endpoints it listens on
and those it dials:

- clear text (``tcp/``, ``udp/``, ``ws/``) beyond loopback is refused unless ``insecure``
  says so in so many words (:meth:`Transport.exposed`);
- a TLS listener beyond loopback that asks neither a certificate (``mtls``) nor a password
  (``passwords``) is refused: anyone who reaches it would be let in without a name.

A unix socket (``unixsock-stream/<path>``) serves clients on the same machine, guarded by
its file permissions.
"""

from __future__ import annotations

import ipaddress
import json
from dataclasses import dataclass
from typing import Any

from .envelope import MAX_MESSAGE

__all__ = ["LINKS", "MAX_LINK_MESSAGE", "MODES", "Transport"]

MODES = ("peer", "client", "router")
LINKS = ("tcp", "udp", "tls", "quic", "ws", "unixsock-stream", "unixpipe", "serial", "vsock")
"""zenoh's link protocols: anything else (``http://rig:7447``) is a typo, not a far rig."""
MAX_LINK_MESSAGE = MAX_MESSAGE + 64 * 1024
"""The largest message a link takes in (zenoh's default is 1 GiB): an envelope at the
protocol's limit, or a live frame with its header. A larger one is dropped as its
fragments arrive, before it is whole in memory, rather than read and then refused."""
_PLAIN = ("tcp", "udp", "ws")
"""Endpoint protocols that carry the bus in clear text."""


@dataclass(frozen=True)
class Transport:
    """Where to listen, whom to dial, and with which credentials.

    >>> t = Transport(connect=("tcp/127.0.0.1:7447",))
    >>> t.config()["scouting"]["multicast"]["enabled"], t.exposed()
    (False, ())
    >>> Transport(connect=("tcp/router.field:7447",), insecure=True).exposed()
    ('tcp/router.field:7447',)
    >>> Transport(listen=("tcp/0.0.0.0:7447",))
    Traceback (most recent call last):
    ValueError: tcp/0.0.0.0:7447 would carry the bus in clear text beyond this machine, ...
    """

    mode: str = "peer"
    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    shared_memory: bool = False
    tls_ca: str = ""
    """PEM file of the CA that signs every certificate of the field network."""
    tls_cert: str = ""
    """This side's certificate (PEM), presented when listening and when dialling."""
    tls_key: str = ""
    mtls: bool = True
    """Mutual TLS: require a certificate from whoever dials us, and present ours when we
    dial (zenoh sends no client certificate without it)."""
    user: str = ""
    """Username/password authentication (``transport/auth/usrpwd``) when dialling."""
    password: str = ""
    passwords: str = ""
    """A ``user:password`` dictionary file checked when others dial us."""
    insecure: bool = False
    """Allow clear-text endpoints beyond loopback, listening or dialling (a lab bench, never
    the field)."""
    access: dict[str, Any] | None = None
    """zenoh's ``access_control`` section (:func:`protocol.access.access_control`)."""

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"zenoh mode {self.mode!r}: use one of {', '.join(MODES)}")
        for ep in (*self.listen, *self.connect):
            proto = ep.split("/", 1)[0]
            if "/" not in ep or proto not in LINKS:
                raise ValueError(
                    f"zenoh endpoint {ep!r}: want proto/address with proto one of "
                    f"{', '.join(LINKS)}, e.g. tcp/127.0.0.1:7447"
                )
        if self.mode == "client" and not self.connect:
            raise ValueError("zenoh client mode needs at least one connect endpoint")
        if any(_tls(ep) for ep in (*self.listen, *self.connect)) and not self.tls_ca:
            raise ValueError("tls/ endpoints need tls_ca (the field network's CA certificate)")
        if any(_tls(ep) for ep in self.listen) and not (self.tls_cert and self.tls_key):
            raise ValueError("listening on tls/ needs tls_cert and tls_key")
        if bool(self.tls_cert) != bool(self.tls_key):
            raise ValueError("tls_cert and tls_key go together")
        if bool(self.user) != bool(self.password):
            raise ValueError("user and password go together")
        if self.exposed() and not self.insecure:
            raise ValueError(
                f"{', '.join(self.exposed())} would carry the bus in clear text beyond this "
                "machine, where anyone on the way could drive the PTU or forge the rig's "
                "telemetry; use tls/ (docs/security.md), loopback or a unix socket, or say "
                "insecure = true (--insecure) for a lab bench"
            )
        anonymous = [ep for ep in self.reachable() if _tls(ep)]
        if anonymous and not (self.mtls or self.passwords):
            raise ValueError(
                f"{', '.join(anonymous)}: mtls = false without passwords would let in anyone "
                "who reaches it, without a name; keep mtls = true (client certificates) or "
                "give passwords"
            )

    def reachable(self) -> tuple[str, ...]:
        """Listen endpoints other machines can reach (not loopback, not a unix socket)."""
        return tuple(ep for ep in self.listen if not _local(ep))

    def loopback(self) -> tuple[str, ...]:
        """Loopback network endpoints, listened on or dialled: every user of this machine
        reaches them, and nothing tells those users apart (unlike a unix socket's mode).

        >>> Transport(listen=("tcp/127.0.0.1:7447", "unixsock-stream//x")).loopback()
        ('tcp/127.0.0.1:7447',)
        """
        return tuple(
            ep for ep in (*self.listen, *self.connect) if _local(ep) and not ep.startswith("unix")
        )

    def unix_sockets(self) -> tuple[str, ...]:
        """Paths of the unix sockets we listen on.

        >>> Transport(listen=("unixsock-stream//run/cyborgd/bus.sock",)).unix_sockets()
        ('/run/cyborgd/bus.sock',)
        """
        return tuple(
            ep.split("/", 1)[1].split("#", 1)[0]
            for ep in self.listen
            if ep.startswith("unixsock-stream/")
        )

    def exposed(self) -> tuple[str, ...]:
        """Endpoints, listened on or dialled, that would carry the bus in clear text beyond
        this machine."""
        return tuple(ep for ep in (*self.listen, *self.connect) if _plain(ep) and not _local(ep))

    def config(self) -> dict[str, Any]:
        """The whole zenoh configuration as nested data."""
        cfg: dict[str, Any] = {
            "mode": self.mode,
            "listen": {"endpoints": list(self.listen)},
            "connect": {"endpoints": list(self.connect)},
            "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
            "transport": {
                "shared_memory": {"enabled": self.shared_memory},
                "link": {"rx": {"max_message_size": MAX_LINK_MESSAGE}},
            },
        }
        if self.tls_ca:
            tls: dict[str, Any] = {"root_ca_certificate": self.tls_ca}
            if self.tls_cert:
                tls |= {
                    "listen_certificate": self.tls_cert,
                    "listen_private_key": self.tls_key,
                    "connect_certificate": self.tls_cert,
                    "connect_private_key": self.tls_key,
                }
            tls["enable_mtls"] = self.mtls and bool(self.tls_cert)  # else no cert is sent
            cfg["transport"]["link"]["tls"] = tls
        usrpwd: dict[str, Any] = {}
        if self.user:
            usrpwd |= {"user": self.user, "password": self.password}
        if self.passwords:
            usrpwd["dictionary_file"] = self.passwords
        if usrpwd:
            cfg["transport"]["auth"] = {"usrpwd": usrpwd}
        if self.access is not None:
            cfg["access_control"] = self.access
        return cfg

    def json5(self) -> str:
        """The configuration for ``zenoh.Config.from_json5``: one recipe for every side."""
        return json.dumps(self.config())


def _plain(endpoint: str) -> bool:
    return endpoint.split("/", 1)[0] in _PLAIN


def _tls(endpoint: str) -> bool:
    return endpoint.startswith(("tls/", "quic/"))


def _local(endpoint: str) -> bool:
    """Whether an endpoint is reachable from this machine only (loopback, unix socket)."""
    proto, address = endpoint.split("/", 1)
    if proto.startswith("unix"):
        return True
    address = address.split("#", 1)[0]
    host = address.rsplit(":", 1)[0].strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False
