"""How every ``cyborg`` client names itself and reaches a rig: one set of options.

Defaults suit the wearable (the daemon listens on 127.0.0.1:7447); ``CYBORG_RIG`` and
``CYBORG_CONNECT`` set them for a shell, e.g. a remote operator dialling a router.
"""

from __future__ import annotations

import argparse
import getpass
import os
import socket

from protocol.transport import Transport

__all__ = ["DEFAULT_ENDPOINT", "add_link_arguments", "transport"]

DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"


def add_link_arguments(parser: argparse.ArgumentParser, role: str) -> None:
    env_connect = os.environ.get("CYBORG_CONNECT", "")
    parser.add_argument(
        "--rig",
        default=os.environ.get("CYBORG_RIG", "rig1"),
        help="the rig's name (its [rig] in cyborgd.toml; env CYBORG_RIG; default rig1)",
    )
    parser.add_argument(
        "--connect",
        action="append",
        metavar="ENDPOINT",
        help="zenoh endpoint of the daemon or a router, repeatable (env CYBORG_CONNECT, "
        f"comma-separated; default {DEFAULT_ENDPOINT})",
        default=None,
    )
    parser.set_defaults(
        env_connect=[e for e in env_connect.split(",") if e.strip()] or [DEFAULT_ENDPOINT]
    )
    parser.add_argument(
        "--name",
        default=f"{role}-{getpass.getuser()}@{socket.gethostname()}",
        help="how this client appears to the rig (who holds control)",
    )


def transport(args: argparse.Namespace, mode: str) -> Transport:
    """``client`` mode fails fast when nothing listens (scripts); ``peer`` mode opens
    anyway and keeps redialling (the keypad and the operator outlive a daemon restart)."""
    return Transport(mode, connect=tuple(args.connect or args.env_connect))
