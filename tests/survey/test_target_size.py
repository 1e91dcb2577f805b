"""How big a target is, at every range of the approach: the survey engine walks a procedural
world (``sim://world``) 300 -> 60 -> 10 m and says the size the world planted: the wet stain
at 300 and 60 m, its shadowed core at 10 m (``bench.sizes`` runs the same walk on more
worlds). The blurred map's patch, the size said before, is twice the stain at 300 m."""

from __future__ import annotations

from pathlib import Path

import pytest

from bench.sizes import walk

pytestmark = pytest.mark.timeout(240)


async def test_the_size_said_is_the_size_planted_at_every_range(tmp_path: Path) -> None:
    stations = await walk(1000, tmp_path)
    assert [s["range_m"] for s in stations] == [300.0, 60.0, 10.0]
    for s in stations:
        assert s["reported_deg"] == pytest.approx(s["planted_deg"], rel=0.25), s
    assert stations[0]["patch_deg"] > 1.5 * stations[0]["planted_deg"]  # the blur's size
