"""Secrets out of what the rig records, publishes and logs.

A camera or PTU URL can carry credentials (``rtsp://user:pass@cam/stream``, or inside a
GStreamer pipeline, ``gst://rtspsrc location=rtsp://user:pass@cam/stream ! ...``); the
session log's metadata, events and log lines carry the URL with its userinfo replaced.
Pure: strings in, strings out.
"""

from __future__ import annotations

import re

__all__ = ["HIDDEN", "redact_url"]

HIDDEN = "***"

_USERINFO = re.compile(r"(?P<scheme>\b[A-Za-z][A-Za-z0-9+.-]*://)[^/\s]*@")
"""A URL's ``scheme://userinfo@``: to the last ``@`` before its path (a password may hold
an unescaped ``@``)."""


def redact_url(text: str) -> str:
    """``text`` with the userinfo of every URL in it replaced by ``***``.

    >>> redact_url("rtsp://user:p@ss@cam.field/stream?x=1")
    'rtsp://***@cam.field/stream?x=1'
    >>> redact_url("gst://rtspsrc location=rtsp://u:pw@10.0.0.9/s ! decodebin ! appsink")
    'gst://rtspsrc location=rtsp://***@10.0.0.9/s ! decodebin ! appsink'
    >>> redact_url("v4l2://0"), redact_url("sim://outcrop?seed=3")
    ('v4l2://0', 'sim://outcrop?seed=3')
    """
    return _USERINFO.sub(rf"\g<scheme>{HIDDEN}@", text)
