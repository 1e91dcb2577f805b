"""``cyborgd router``: the field network's zenoh router, TLS with client certificates and
an access-control list generated from the users file.

Operators and viewers dial the router; the rig dials it too (or listens itself). Every
link is mutual TLS: the certificate's common name is who a peer is, and
:func:`protocol.access.access_control` says what that name may do with the rig's keys.
Users without a certificate may authenticate with a username and password (``passwords``,
zenoh's ``user:password`` dictionary file) over TLS.

router.toml (relative paths are from its folder)::

    rig = "rig1"                       # the rig whose keys the list covers
    listen = ["tls/0.0.0.0:7448"]
    tls_ca = "/etc/cyborgd/tls/ca.crt"
    tls_cert = "/etc/cyborgd/tls/router.crt"
    tls_key = "/etc/cyborgd/tls/router.key"
    users = "/etc/cyborgd/users.toml"
    # passwords = "/etc/cyborgd/passwords"   # optional usrpwd dictionary (user:password lines)
    # mtls = false                           # let password users in without a certificate
    # insecure = false                       # clear text beyond loopback: never in the field
"""

from __future__ import annotations

import asyncio
import json
import logging
import signal
import sys
import tomllib
from pathlib import Path
from typing import Any, TextIO

import zenoh

from cyborg.protocol.access import access_control, load_users
from cyborg.protocol.keys import Keys
from cyborg.protocol.link import ADMIN_SPACE, locators, open_session
from cyborg.protocol.transport import Transport

from .zenohlog import route_zenoh_logs

__all__ = ["load_router", "run_router"]

_LOGGER = logging.getLogger(__name__)
_KEYS = {"rig", "listen", "tls_ca", "tls_cert", "tls_key", "mtls", "users", "passwords", "insecure"}


def load_router(path: Path) -> Transport:
    """router.toml -> the router's Transport; ValueError naming what is wrong."""
    try:
        data: dict[str, Any] = tomllib.loads(path.read_text())
    except OSError as exc:
        raise ValueError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: not valid TOML: {exc}") from None
    unknown = sorted(set(data) - _KEYS)
    if unknown:
        raise ValueError(f"{path}: unknown key(s): {', '.join(unknown)}")
    for required in ("rig", "listen", "users"):
        if required not in data:
            raise ValueError(f"{path}: {required} is required")
    for name in ("tls_ca", "tls_cert", "tls_key", "users", "passwords"):  # from its folder
        if data.get(name):
            data[name] = str(path.parent / str(data[name]))
    keys = Keys(str(data["rig"]))
    users_file = Path(str(data["users"]))
    try:
        users = load_users(users_file.read_text(), keys.rig)
    except OSError as exc:
        raise ValueError(f"users: {users_file}: {exc.strerror or exc}") from None
    except ValueError as exc:
        raise ValueError(f"users: {users_file}: {exc}") from None
    return Transport(  # refuses clear text and anonymous TLS beyond loopback
        "router",
        listen=tuple(data["listen"]),
        tls_ca=str(data.get("tls_ca", "")),
        tls_cert=str(data.get("tls_cert", "")),
        tls_key=str(data.get("tls_key", "")),
        mtls=bool(data.get("mtls", True)),
        passwords=str(data.get("passwords", "")),
        insecure=bool(data.get("insecure", False)),
        access=access_control(keys, users, local=False),
    )


async def _serve(transport: Transport, ready: TextIO) -> int:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)
    if transport.exposed():
        _LOGGER.warning("insecure: clear-text endpoints beyond loopback: %s", transport.exposed())
    session = open_session(transport, ADMIN_SPACE)
    try:
        ready_line = {"ready": True, "locators": locators(session)}
        print(json.dumps(ready_line), file=ready, flush=True)
        await stop.wait()
    finally:
        session.close()
    return 0


def run_router(path: Path) -> int:
    try:
        transport = load_router(path)
    except ValueError as exc:
        print(f"cyborgd router: {exc}", file=sys.stderr)
        return 2
    try:
        return asyncio.run(_serve(transport, route_zenoh_logs()))
    except zenoh.ZError as exc:
        print(f"cyborgd router: {exc}", file=sys.stderr)
        return 1
