"""Intelligent zoom end to end: a real daemon with an OpenCV camera (a video file) whose
lens zooms over VISCA (the emulator on a pty); choosing a target zooms on it instead of
walking, and the manifest says how far and how long it took."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from cyborg.clients.rigclient import RigClient, run_station
from cyborg.daemon.camera.visca import ViscaEmulator
from cyborg.protocol.messages import (
    ChooseTarget,
    InterestResult,
    SurveyProgress,
    SurveyStart,
    TakeControl,
)

pytestmark = pytest.mark.timeout(120)


def _clip(path: Path) -> None:
    """A few seconds of a textured scene with a green spot, as a camera file."""
    rng = np.random.default_rng(1)
    out = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (320, 240))
    for _ in range(30):
        frame = np.clip(rng.normal(120, 12, (240, 320, 3)), 0, 255).astype(np.uint8)
        cv2.circle(frame, (200, 90), 9, (40, 170, 40), -1)
        out.write(frame)
    out.release()


async def test_choosing_zooms_on_the_target_instead_of_walking(
    start_daemon, client: RigClient, tmp_path: Path
) -> None:
    video = tmp_path / "camera.avi"
    _clip(video)
    lens = await ViscaEmulator(full_travel=0.3).start()
    try:
        camera = {
            "url": f"file://{video}?loop=1",
            "hfov": 30.0,
            "zoom": f"visca://{lens.path}?max=30",
        }
        daemon = await start_daemon(
            sections={"camera": camera}, simulate_approach=False, zoom_on_target=True
        )
        await client.wait_alive()
        progress = client.subscribe(client.keys.progress, SurveyProgress)
        results = client.subscribe(client.keys.result, InterestResult)
        await client.command(TakeControl())
        result = await run_station(client, progress, results, SurveyStart(rows=1, cols=2))
        ack = await client.command(ChooseTarget(result.station, 1))
        assert "60 m" in ack.detail
        manifest = Path(daemon.ready["archive"]) / result.station / "manifest.json"
        zoom = json.loads(manifest.read_text())["choice"]["zoom"]
        assert zoom["level"] == 5.0 and "seconds" in zoom  # 300 m to 60 m, and its time
        assert lens.position == round(0x4000 * np.log(5.0) / np.log(30.0))
    finally:
        await lens.close()
