"""The operator console in a small box: ``cyborg operator`` as a process with 256 open files,
a flood of slow-header connections from the operator's own address, and the operator's own
request still served, every slow connection closed by the console, and no traceback."""

from __future__ import annotations

import asyncio
from pathlib import Path

import pytest

from bench.console import operator_request, slow_header
from cyborg.clients.launch import operator as launch_operator

pytestmark = pytest.mark.timeout(240)

FLOOD = 400
NOFILE = 256
GIVE_UP_S = 150.0
"""How long a slow client waits to be closed before the test calls it kept open."""


async def test_a_slow_header_flood_does_not_keep_the_operator_out(
    router: str, tmp_path: Path
) -> None:
    log = tmp_path / "operator.log"
    async with launch_operator(router, "itest", "remote-op", log, nofile=NOFILE) as url:
        host, port = url.removeprefix("http://").split("/", 1)[0].rsplit(":", 1)
        flood = [asyncio.create_task(slow_header(host, int(port), GIVE_UP_S)) for _ in range(FLOOD)]
        await asyncio.sleep(1.0)  # the flood lands first
        served = await operator_request(url)
        held = await asyncio.gather(*flood)
    assert served["served"], served
    connected = [s for s in held if s is not None]
    assert len(connected) > NOFILE  # more than the console has files for
    assert all(s < GIVE_UP_S for s in connected)  # and every one closed by the console
    assert b"Traceback" not in log.read_bytes()
