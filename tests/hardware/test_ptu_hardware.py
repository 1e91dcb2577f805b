"""A real PTU on a serial port: runs only with ``--ptu-port=/dev/...``.

It moves the head by a few degrees around where it is and back, so keep the tripod clear.
"""

from __future__ import annotations

import pytest

from cyborg.daemon.ptu import LinkState, PtuLimitError, SerialPtu

pytestmark = pytest.mark.timeout(120)


async def test_real_unit_round_trip(ptu_port: str) -> None:
    async with SerialPtu(ptu_port) as unit:
        assert unit.state is LinkState.READY
        info = unit.info
        print(f"\n{info.version}\npan {info.pan}\ntilt {info.tilt}")
        start = await unit.position()
        here = await unit.move_by(pan=5.0, tilt=2.0)
        assert here.pan == pytest.approx(start.pan + 5.0, abs=2 * info.pan.degrees_per_position)
        with pytest.raises(PtuLimitError):
            await unit.move_to(info.pan.max_deg + 1.0)
        await unit.move_to(start.pan, start.tilt)
