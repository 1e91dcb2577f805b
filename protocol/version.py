"""Protocol version: a major mismatch is refused, a minor difference is tolerated.

2.0: commands carry the caller's name in their key (``cmd/<client>/<verb>``) and the rig
binds control to it; a 1.x peer is refused with "protocol 2 required".
2.1: interest points carry azimuth and elevation; a status, the result awaiting a choice.
2.2: a survey start may carry the station's parameter settings (``NAME=VALUE``).
2.3: a status carries the PTU's position step (``ptu_step``), read from the unit.
2.4: an interest point says whether it stands out from its view (``target``; false: "no
further target", its score indistinguishable from the view's background).
2.5: a survey start may carry the station's aim of study (``aim``, ``protocol.aims``); a
result says the aim its station sought, a status the aim the next station takes unasked.
"""

from __future__ import annotations

import importlib.metadata

BUILD = importlib.metadata.version("cyborg-astrobiologist")
"""This installation's version (``cyborgd --version``, ``cyborg --version``, ``hello``)."""

PROTOCOL_MAJOR = 2
PROTOCOL_MINOR = 5


def compatible(major: int) -> bool:
    """Peers talk if and only if their majors agree (new minors only add optional fields).

    >>> compatible(2), compatible(1)
    (True, False)
    """
    return major == PROTOCOL_MAJOR
