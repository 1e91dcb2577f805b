"""The daemon's bus with a subscriber that stopped reading: nothing it sends may block the
event loop, since a HALT waits behind it.

The daemon's side is the real :class:`Bus` on a real zenoh session; the stalled viewer is a
real process subscribed to everything, frozen with SIGSTOP. zenoh is told to give the
stalled link a minute (``wait_before_close``, where the default is 5 s), so a put that
blocks would block far longer than the test may take: every step below either finishes
or the test times out.
"""

from __future__ import annotations

import asyncio
import signal
from collections.abc import Iterator

import pytest

from cyborg.clients.launch import free_port, watcher
from cyborg.daemon.bus import OUTBOX_BOUND, Bus
from cyborg.protocol.envelope import decode, encode
from cyborg.protocol.keys import Keys
from cyborg.protocol.link import open_session
from cyborg.protocol.messages import Ack, Event, FrameHeader, PtuState
from cyborg.protocol.transport import Transport

pytestmark = pytest.mark.timeout(120)

STALL_US = 60 * 10**6


@pytest.fixture
def bus() -> Iterator[tuple[Bus, str]]:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    never_close = {
        "transport/link/tx/queue/congestion_control/block/wait_before_close": str(STALL_US)
    }
    bus = Bus(open_session(Transport(listen=(endpoint,)), never_close), Keys("stall"))
    try:
        yield bus, endpoint
    finally:
        bus.close()


async def _matched(bus: Bus) -> None:
    async with asyncio.timeout(60):
        while not bus.frame_wanted():
            await asyncio.sleep(0.05)


async def test_a_frozen_viewer_neither_blocks_the_loop_nor_a_command(bus) -> None:
    bus, endpoint = bus

    async def handler(client: str, verb: str, payload: bytes) -> bytes:
        return bus.envelope(Ack("OK", f"{verb} from {client}"))

    serving = asyncio.create_task(bus.serve(bus.declare_commands(), handler))
    try:
        async with watcher(endpoint, f"{bus.keys.root}/**") as viewer:
            await _matched(bus)
            viewer.send_signal(signal.SIGSTOP)
            jpeg = bytes(200_000)
            header = FrameHeader(1, 720, 576, 0.0, 0.0)
            # Far more than the link's buffers hold: frames fill them, then every reliable
            # message waits for a reader that never comes.
            for i in range(4 * OUTBOX_BOUND):
                bus.publish_frame(jpeg, header)
                bus.publish(bus.keys.ptu_state, PtuState(0.0, 0.0, False), latest_wins=True)
                bus.publish(bus.keys.events, Event("info", f"event {i}"))
                await asyncio.sleep(0)
            # The reliable messages' bound held: the oldest waiting were dropped, not queued
            # without end (and not blocking, or this line would never be reached).
            async with asyncio.timeout(60):
                while bus._outbox.dropped == 0:
                    bus.publish_frame(jpeg, header)
                    bus.publish(bus.keys.events, Event("info", "more"))
                    await asyncio.sleep(0.01)
            # A healthy client's command is answered while the viewer is still frozen.
            with open_session(Transport("client", connect=(endpoint,))) as client:
                key = bus.keys.cmd("alice", "ptu/halt")
                replies = await asyncio.to_thread(
                    lambda: list(client.get(key, payload=encode("ptu.halt", {}), timeout=30))
                )
            assert replies and replies[0].ok is not None
            assert decode(replies[0].ok.payload.to_bytes()).body["detail"] == "ptu/halt from alice"
            assert viewer.returncode is None  # still frozen: nothing waited for it
    finally:
        serving.cancel()
        await asyncio.gather(serving, return_exceptions=True)
