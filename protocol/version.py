"""Protocol version: a major mismatch is refused, a minor difference is tolerated."""

from __future__ import annotations

PROTOCOL_MAJOR = 1
PROTOCOL_MINOR = 1


def compatible(major: int) -> bool:
    """Peers talk if and only if their majors agree (new minors only add optional fields).

    >>> compatible(1), compatible(2)
    (True, False)
    """
    return major == PROTOCOL_MAJOR
