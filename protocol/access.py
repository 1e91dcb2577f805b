"""Who may do what on a rig's bus: a small users file turned into zenoh's access control.

A principal is a certificate common name (mutual TLS) or a username (zenoh's user/password
authentication), and it is the same name the client puts in its command keys
(``cmd/<client>/<verb>``). The generated rules let a principal query only its own key
segment, so it cannot speak for anyone else, and let nobody but the rig itself publish
the rig's telemetry. Roles:

* ``operator``: every command, all telemetry and frames;
* ``viewer``: telemetry, frames and the commands that change nothing (``READ_ONLY`` on
  their request class: ``hello``, ``survey/status``, ``cam/stream`` and the archive).

Clients on the rig's own unix socket (``unixsock-stream``) may send any command under any
name: the socket's file permissions are their credential. They cannot publish telemetry.
Whatever no rule allows is denied.

The users file (TOML)::

    rig = "rig1"                  # the rig's certificate CN (default: the rig's name)
    [[user]]
    name = "alice"                # certificate CN or username = the client name
    role = "operator"
    [[user]]
    name = "bob"
    role = "viewer"
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from typing import Any

from .keys import COMMANDS, Keys, check_client
from .messages import REQUESTS

__all__ = ["ROLES", "User", "Users", "access_control", "load_users"]

ROLES: dict[str, tuple[str, ...]] = {
    "operator": COMMANDS,
    "viewer": tuple(verb for verb, request in REQUESTS.items() if request.READ_ONLY),
}
"""The command verbs each role may send (a viewer: those ``Request.READ_ONLY``)."""

_FROM_CLIENT = ["declare_subscriber", "declare_liveliness_subscriber", "liveliness_query"]
_TO_CLIENT = ["put", "delete", "reply", "liveliness_token", "declare_queryable"]
"""``declare_queryable`` too: a client in peer mode (the keypad, the console) routes its
queries only to queryables it has been told of."""
_EVERYTHING = [
    "put",
    "delete",
    "declare_subscriber",
    "query",
    "reply",
    "declare_queryable",
    "liveliness_token",
    "liveliness_query",
    "declare_liveliness_subscriber",
]


@dataclass(frozen=True)
class User:
    name: str
    role: str

    def __post_init__(self) -> None:
        check_client(self.name)
        if self.role not in ROLES:
            raise ValueError(f"user {self.name}: role {self.role!r}: use {' or '.join(ROLES)}")


@dataclass(frozen=True)
class Users:
    rig: str
    """The rig's own principal (its certificate CN), allowed everything under its keys."""
    users: tuple[User, ...]


def load_users(text: str, default_rig: str) -> Users:
    """Parse a users file; ValueError naming the problem.

    >>> u = load_users('[[user]]\\nname = "alice"\\nrole = "operator"', "rig1")
    >>> u.rig, u.users
    ('rig1', (User(name='alice', role='operator'),))
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"not valid TOML: {exc}") from None
    unknown = sorted(set(data) - {"rig", "user"})
    if unknown:
        raise ValueError(f"unknown key(s): {', '.join(unknown)}")
    rig = data.get("rig", default_rig)
    entries = data.get("user", [])
    if not isinstance(rig, str) or not isinstance(entries, list):
        raise ValueError("rig is a name and [[user]] a list of tables")
    users = []
    for entry in entries:
        if not isinstance(entry, dict) or set(entry) != {"name", "role"}:
            raise ValueError(f"each [[user]] has exactly a name and a role, not {entry!r}")
        users.append(User(str(entry["name"]), str(entry["role"])))
    names = [u.name for u in users]
    duplicates = sorted({n for n in names if names.count(n) > 1} | ({rig} & set(names)))
    if duplicates:
        raise ValueError(f"name(s) given twice: {', '.join(duplicates)}")
    return Users(check_client(rig), tuple(users))


def access_control(keys: Keys, users: Users, *, local: bool = True) -> dict[str, Any]:
    """zenoh's ``access_control`` section for one rig: default deny, one rule set per user.

    With ``local`` the rig's unix-socket clients are operators (a router has none).
    """
    everything = keys.root + "/**"
    rules: list[dict[str, Any]] = [
        _rule("rig", _EVERYTHING, ["ingress", "egress"], [everything]),
        _rule("watch", _FROM_CLIENT, ["ingress"], [everything]),
        _rule("receive", _TO_CLIENT, ["egress"], [everything]),
    ]
    subjects: list[dict[str, Any]] = [
        {"id": "rig", "cert_common_names": [users.rig]},
        {"id": "rig-user", "usernames": [users.rig]},  # where passwords stand in for certs
    ]
    policies: list[dict[str, Any]] = [{"rules": ["rig"], "subjects": ["rig", "rig-user"]}]
    for user in users.users:
        verbs = ROLES[user.role]
        commands = (
            [keys.commands_of(user.name)]
            if verbs == COMMANDS
            else [keys.cmd(user.name, verb) for verb in verbs]
        )
        rules.append(_rule(f"cmd-{user.name}", ["query"], ["ingress"], commands))
        # A name is a certificate CN or a username; one subject each, same rules.
        subjects.append({"id": f"cn-{user.name}", "cert_common_names": [user.name]})
        subjects.append({"id": f"user-{user.name}", "usernames": [user.name]})
        policies.append(
            {
                "rules": ["watch", "receive", f"cmd-{user.name}"],
                "subjects": [f"cn-{user.name}", f"user-{user.name}"],
            }
        )
    if local:
        rules.append(_rule("cmd-local", ["query"], ["ingress"], [keys.all_commands]))
        subjects.append({"id": "local", "link_protocols": ["unixsock-stream"]})
        policies.append({"rules": ["watch", "receive", "cmd-local"], "subjects": ["local"]})
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
    }


def _rule(rid: str, messages: list[str], flows: list[str], key_exprs: list[str]) -> dict:
    return {
        "id": rid,
        "messages": messages,
        "flows": flows,
        "permission": "allow",
        "key_exprs": key_exprs,
    }
