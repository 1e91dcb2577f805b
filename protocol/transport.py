"""How a rig's peers find each other: the zenoh settings both sides apply, as plain data.

Multicast and gossip scouting stay off everywhere: endpoints are always explicit, so a
field network (or two test runs on one machine) never joins the wrong rig by accident.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

__all__ = ["MODES", "Transport"]

MODES = ("peer", "client", "router")


@dataclass(frozen=True)
class Transport:
    """Where to listen and whom to dial.

    >>> Transport(connect=("tcp/127.0.0.1:7447",)).settings()["scouting/multicast/enabled"]
    False
    """

    mode: str = "peer"
    listen: tuple[str, ...] = ()
    connect: tuple[str, ...] = ()
    shared_memory: bool = False

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

    def settings(self) -> dict[str, Any]:
        return {
            "mode": self.mode,
            "listen/endpoints": list(self.listen),
            "connect/endpoints": list(self.connect),
            "scouting/multicast/enabled": False,
            "scouting/gossip/enabled": False,
            "transport/shared_memory/enabled": self.shared_memory,
        }

    def json5_items(self) -> list[tuple[str, str]]:
        """(key, JSON value) pairs for ``zenoh.Config.insert_json5``."""
        return [(k, json.dumps(v)) for k, v in self.settings().items()]
