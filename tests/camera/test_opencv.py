"""The OpenCV backend on real video files: frames, end of file, reconnect."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from cyborg.daemon.camera import CameraUnavailableError, OpenCvCamera, open_camera


def _write_clip(path: Path, n: int = 6) -> None:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25, (64, 48))
    assert writer.isOpened()
    for k in range(n):
        writer.write(np.full((48, 64, 3), 20 + 30 * k, np.uint8))
    writer.release()


def _level(frame) -> int:
    return round(float(frame.image.mean()))


async def test_file_frames_then_reconnect_at_the_end(tmp_path: Path) -> None:
    clip = tmp_path / "clip.avi"
    _write_clip(clip)
    cam = open_camera(f"file://{clip}")
    assert isinstance(cam, OpenCvCamera)
    async with cam:
        assert cam.resolution == (64, 48)
        levels = [_level(await cam.grab()) for _ in range(6)]
        assert levels == pytest.approx([20, 50, 80, 110, 140, 170], abs=3)
        # The source stops delivering: the backend reopens it and goes on.
        again = await cam.grab()
        assert cam.reconnects == 1 and _level(again) == pytest.approx(20, abs=3)
        assert again.seq == 7 and again.image.dtype == np.uint8


async def test_loop_rewinds_without_reconnecting(tmp_path: Path) -> None:
    clip = tmp_path / "clip.avi"
    _write_clip(clip, 2)
    async with open_camera(f"file://{clip}?loop=1") as cam:
        levels = [_level(await cam.grab()) for _ in range(5)]
        assert levels == pytest.approx([20, 50, 20, 50, 20], abs=3)
        assert cam.reconnects == 0  # type: ignore[attr-defined]


async def test_missing_source_then_it_appears(tmp_path: Path) -> None:
    clip = tmp_path / "late.avi"
    cam = OpenCvCamera(str(clip), retries=2, backoff=0.01)
    with pytest.raises(CameraUnavailableError, match="no such file"):
        await cam.open()
    with pytest.raises(CameraUnavailableError, match="no frame after 2 reconnect"):
        await cam.grab()
    _write_clip(clip)
    frame = await cam.grab()
    assert _level(frame) == pytest.approx(20, abs=3)
    await cam.close()


async def test_not_a_video(tmp_path: Path) -> None:
    junk = tmp_path / "junk.avi"
    junk.write_bytes(b"\x00" * 100)
    with pytest.raises(CameraUnavailableError, match="cannot open"):
        await OpenCvCamera(str(junk)).open()
