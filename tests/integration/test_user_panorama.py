"""A user's own panorama on the simulated camera, through the daemon: the configured 2x3 mosaic
would reach below the image, so ``survey/start`` is refused with the limits, and the head
stays where it was."""

from __future__ import annotations

import asyncio
from pathlib import Path

import cv2
import numpy as np
import pytest

from cyborg.clients.rigclient import RigClient
from cyborg.protocol.messages import Ack, PtuState, SurveyStart, TakeControl

pytestmark = pytest.mark.timeout(120)


async def test_a_plan_past_a_users_panorama_is_refused_with_its_limits(
    start_daemon, client: RigClient, tmp_path: Path, rng: np.random.Generator
) -> None:
    pano = tmp_path / "huge.jpg"
    assert cv2.imwrite(str(pano), rng.integers(40, 220, (320, 960, 3), dtype=np.uint8))
    url = f"sim://{pano}?pan=-60,60&tilt=-20,20&hfov=30"
    await start_daemon(sections={"camera": {"url": url}})
    await client.wait_alive()
    states = client.subscribe(client.keys.ptu_state, PtuState)
    await client.command(TakeControl())
    reply = await client.call(SurveyStart())
    assert isinstance(reply, Ack) and reply.result == "REJECTED"
    assert reply.detail == (
        "survey/start: the 2×3 mosaic at pan 0.0, tilt 0.0 reaches tilt -24.2° and tilt "
        "24.2°; the camera's scene shows pan -60..60°, tilt -20..20°"
    )
    state = await asyncio.wait_for(states.get(), 10)
    assert (state.pan, state.tilt, state.moving) == (0.0, 0.0, False)
