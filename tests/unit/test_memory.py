"""Novelty against history: a colour no earlier station showed is new, one it showed is not."""

from __future__ import annotations

import numpy as np

from daemon.memory import NEW_DE, SessionMemory, phrase


def test_new_is_what_no_earlier_station_showed() -> None:
    memory = SessionMemory()
    outcrop = np.full((60, 80, 3), (110, 140, 170), np.uint8)  # buff rock
    assert memory.novelty(outcrop, 10, 10, 4) is None  # nothing seen yet
    memory.remember("st01-300m", outcrop)
    closer = outcrop.copy()
    closer[20:32, 30:42] = (40, 170, 40)  # a plant the walk revealed
    new = memory.novelty(closer, 36, 26, 6)
    seen = memory.novelty(closer, 5, 5, 3)
    assert new is not None and new[0] > NEW_DE and phrase(new, "st01-300m") == "new since st01-300m"
    assert seen is not None and seen[0] < 1.0 and phrase(seen, "st01-300m") == "seen at st01-300m"
    memory.clear()
    assert memory.novelty(closer, 36, 26, 6) is None
