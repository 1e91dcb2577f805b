"""The driver tests' unit: the emulator behind the real serial driver."""

from __future__ import annotations

import pytest

from cyborg.daemon.ptu import PtyPtu
from cyborg.daemon.ptu.emulated import TcpPtu
from cyborg.daemon.ptu.emulator import Ptu46Emulator


@pytest.fixture(params=["pty", "tcp"])
async def ptu(request):
    """The emulator behind the real driver: on a pty, and behind a TCP line server as a
    PTU-E46 or a terminal server is reached (``tcp://``, pyserial's ``socket://``)."""
    kind = PtyPtu if request.param == "pty" else TcpPtu
    unit = kind(Ptu46Emulator(time_scale=20), baud=0)
    await unit.open()
    yield unit
    await unit.close()
