"""Credentials in a camera URL never reach a message or a log line: the URL's userinfo is
replaced wherever it is shown (the session log's metadata and the archive are checked on
a real daemon in tests/integration/test_session_log_recovery.py)."""

from __future__ import annotations

import logging

import pytest

from cyborg.daemon.camera import CameraUnavailableError, OpenCvCamera
from cyborg.protocol.redact import redact_url

SECRET = "s3cr3t-pw"


@pytest.mark.parametrize(
    ("url", "shown"),
    [
        (f"rtsp://admin:{SECRET}@cam.field:554/stream1", "rtsp://***@cam.field:554/stream1"),
        (f"rtsp://admin:p@{SECRET}@10.0.0.9/s", "rtsp://***@10.0.0.9/s"),
        (f"http://{SECRET}@cam/video.mjpg", "http://***@cam/video.mjpg"),
        (
            f"gst://rtspsrc location=rtsp://u:{SECRET}@cam/s latency=0 ! decodebin ! appsink",
            "gst://rtspsrc location=rtsp://***@cam/s latency=0 ! decodebin ! appsink",
        ),
        ("rtsp://cam.field/stream1", "rtsp://cam.field/stream1"),
        ("v4l2://0", "v4l2://0"),
        ("serial:///dev/ptu?baud=9600", "serial:///dev/ptu?baud=9600"),
        ("/dev/video2", "/dev/video2"),
    ],
)
def test_a_url_is_shown_without_its_userinfo(url: str, shown: str) -> None:
    assert redact_url(url) == shown


async def test_an_unreachable_rtsp_camera_says_so_without_its_password(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """Port 9 on loopback refuses at once: the open fails, the reconnects are logged, the
    grab fails; every text names the camera, none carries the password."""
    caplog.set_level(logging.DEBUG, logger="cyborg.daemon.camera")
    cam = OpenCvCamera(f"rtsp://admin:{SECRET}@127.0.0.1:9/stream", retries=1, backoff=0.01)
    with pytest.raises(CameraUnavailableError) as opened:
        await cam.open()
    with pytest.raises(CameraUnavailableError) as grabbed:
        await cam.grab()
    await cam.close()
    texts = [str(opened.value), str(grabbed.value), *(r.getMessage() for r in caplog.records)]
    assert len(texts) >= 4  # both errors, the reconnect's warning and its failure
    assert all("rtsp://***@127.0.0.1:9/stream" in t for t in texts), texts
    assert not [t for t in texts if SECRET in t]
