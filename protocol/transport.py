"""How a rig's peers find and trust each other: the zenoh settings both sides apply, as data.

Multicast and gossip scouting stay off everywhere: endpoints are always explicit, so a
field network (or two test runs on one machine) never joins the wrong rig by accident.

Links beyond the machine are TLS with mutual authentication (``tls/`` endpoints, a CA,
this side's certificate and key); the certificate's common name is who a peer is, and an
access-control section (:mod:`protocol.access`) says what each name may do. Plain TCP or
UDP on anything but loopback is refused unless ``insecure`` says so in so many words
(:meth:`Transport.exposed`). A unix socket (``unixsock-stream/<path>``) serves clients on
the same machine, guarded by its file permissions.
"""

from __future__ import annotations

import ipaddress
import json
from dataclasses import dataclass
from typing import Any

__all__ = ["MODES", "Transport"]

MODES = ("peer", "client", "router")
_PLAIN = ("tcp", "udp", "ws")
"""Endpoint protocols that carry the bus in clear text."""


@dataclass(frozen=True)
class Transport:
    """Where to listen, whom to dial, and with which credentials.

    >>> t = Transport(connect=("tcp/127.0.0.1:7447",))
    >>> t.config()["scouting"]["multicast"]["enabled"], t.exposed()
    (False, ())
    >>> Transport(listen=("tcp/0.0.0.0:7447",)).exposed()
    ('tcp/0.0.0.0:7447',)
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
    """Allow clear-text endpoints beyond loopback (a lab bench, never the field)."""
    access: dict[str, Any] | None = None
    """zenoh's ``access_control`` section (:func:`protocol.access.access_control`)."""

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"zenoh mode {self.mode!r}: use one of {', '.join(MODES)}")
        for ep in (*self.listen, *self.connect):
            if "/" not in ep:
                raise ValueError(
                    f"zenoh endpoint {ep!r}: want proto/address, e.g. tcp/127.0.0.1:7447"
                )
        if self.mode == "client" and not self.connect:
            raise ValueError("zenoh client mode needs at least one connect endpoint")
        uses_tls = any(ep.startswith(("tls/", "quic/")) for ep in (*self.listen, *self.connect))
        if uses_tls and not self.tls_ca:
            raise ValueError("tls/ endpoints need tls_ca (the field network's CA certificate)")
        if any(ep.startswith(("tls/", "quic/")) for ep in self.listen) and not (
            self.tls_cert and self.tls_key
        ):
            raise ValueError("listening on tls/ needs tls_cert and tls_key")
        if bool(self.tls_cert) != bool(self.tls_key):
            raise ValueError("tls_cert and tls_key go together")
        if bool(self.user) != bool(self.password):
            raise ValueError("user and password go together")

    def reachable(self) -> tuple[str, ...]:
        """Listen endpoints other machines can reach (not loopback, not a unix socket)."""
        return tuple(ep for ep in self.listen if not _local(ep))

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
        """Listen endpoints that would carry the bus in clear text beyond this machine."""
        return tuple(ep for ep in self.reachable() if _plain(ep))

    def config(self) -> dict[str, Any]:
        """The whole zenoh configuration as nested data."""
        cfg: dict[str, Any] = {
            "mode": self.mode,
            "listen": {"endpoints": list(self.listen)},
            "connect": {"endpoints": list(self.connect)},
            "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
            "transport": {"shared_memory": {"enabled": self.shared_memory}},
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
            cfg["transport"]["link"] = {"tls": tls}
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
