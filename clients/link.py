"""How every ``cyborg`` client names itself and reaches a rig: one set of options.

Defaults suit the wearable: the installed daemon's unix socket, else 127.0.0.1:7447.
Environment variables set them for a shell, e.g. a remote operator dialling the field
router over TLS:
``CYBORG_RIG``, ``CYBORG_CONNECT`` (comma-separated), ``CYBORG_NAME``, ``CYBORG_TLS_CA``,
``CYBORG_TLS_CERT``, ``CYBORG_TLS_KEY``, ``CYBORG_USER``, ``CYBORG_PASSWORD_FILE`` and
``CYBORG_INSECURE`` (any value: dial clear text beyond loopback, as ``cyborgd --insecure``).
The name must be the certificate's common name (or the username): the rig knows a client
by the name in its command keys, and the router lets it use only its own.
"""

from __future__ import annotations

import argparse
import getpass
import os
import re
import socket
from pathlib import Path

from cyborg.protocol.transport import Transport

__all__ = [
    "DEFAULT_ENDPOINT",
    "RIG_SOCKET",
    "add_link_arguments",
    "default_endpoint",
    "default_name",
    "transport",
]

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"
RIG_SOCKET = Path("/run/cyborgd/bus.sock")
"""The installed daemon's unix socket (systemd/cyborgd.toml): preferred when it exists."""


def default_endpoint() -> str:
    """The wearable's own daemon: its unix socket if installed, else loopback TCP."""
    return f"unixsock-stream/{RIG_SOCKET}" if RIG_SOCKET.is_socket() else DEFAULT_ENDPOINT


def default_name(role: str) -> str:
    """``role-user.host``, cut down to a valid client name.

    >>> default_name("keypad").startswith("keypad-")
    True
    """
    raw = f"{role}-{getpass.getuser()}.{socket.gethostname()}"
    return re.sub(r"[^A-Za-z0-9._-]", "-", raw)[:64]


def add_link_arguments(parser: argparse.ArgumentParser, role: str) -> None:
    env = os.environ.get
    parser.add_argument(
        "--rig",
        default=env("CYBORG_RIG", "rig1"),
        help="the rig's name (its [rig] in cyborgd.toml; env CYBORG_RIG; default rig1)",
    )
    parser.add_argument(
        "--connect",
        action="append",
        metavar="ENDPOINT",
        help="zenoh endpoint of the daemon or a router, repeatable (env CYBORG_CONNECT, "
        f"comma-separated; default unixsock-stream/{RIG_SOCKET} if it exists, else "
        f"{DEFAULT_ENDPOINT})",
        default=None,
    )
    parser.set_defaults(
        env_connect=[e for e in env("CYBORG_CONNECT", "").split(",") if e.strip()]
        or [default_endpoint()]
    )
    parser.add_argument(
        "--name",
        default=env("CYBORG_NAME") or default_name(role),
        help="who this client is to the rig: 1-64 letters, digits, '.', '_', '-'; over TLS, "
        "the certificate's common name (env CYBORG_NAME)",
    )
    tls = parser.add_argument_group("TLS (tls/ endpoints)")
    tls.add_argument("--tls-ca", default=env("CYBORG_TLS_CA", ""), metavar="PEM")
    tls.add_argument("--tls-cert", default=env("CYBORG_TLS_CERT", ""), metavar="PEM")
    tls.add_argument("--tls-key", default=env("CYBORG_TLS_KEY", ""), metavar="PEM")
    tls.add_argument("--user", default=env("CYBORG_USER", ""), help="username/password login")
    tls.add_argument(
        "--password-file", default=env("CYBORG_PASSWORD_FILE", ""), type=str, metavar="FILE"
    )
    tls.add_argument(
        "--insecure",
        action="store_true",
        default=bool(env("CYBORG_INSECURE")),
        help="allow dialling clear-text tcp/ beyond loopback (a lab bench, never the field)",
    )


def transport(args: argparse.Namespace, mode: str) -> Transport:
    """``client`` mode fails fast when nothing listens (scripts); ``peer`` mode opens
    anyway and keeps redialling (the keypad and the operator outlive a daemon restart).
    Raises ValueError for unusable link options (a missing CA for tls/, no password...)."""
    password = ""
    if args.user:
        if not args.password_file:
            raise ValueError("--user needs --password-file")
        password = Path(args.password_file).read_text().strip()
    return Transport(
        mode,
        connect=tuple(args.connect or args.env_connect),
        tls_ca=args.tls_ca,
        tls_cert=args.tls_cert,
        tls_key=args.tls_key,
        user=args.user,
        password=password,
        insecure=args.insecure,
    )
