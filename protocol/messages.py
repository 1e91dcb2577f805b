"""Every message of the protocol, by kind: the one import point for both sides.

The messages live by role: :mod:`.base` (the ``Message`` base and its strict, tolerant
decoding), :mod:`.replies` (answers and telemetry), :mod:`.requests` (the commands, one
class per verb) and :mod:`.settings` (a station's ``NAME=VALUE`` settings). They are all
re-exported here, with the registry of kinds that decoding uses.
"""

from __future__ import annotations

from typing import Any

from .base import MAX_TEXT, RESULTS, Message, clip
from .replies import (
    Ack,
    ArchiveData,
    ArchiveListing,
    Chip,
    Event,
    FrameHeader,
    FrameStream,
    InterestPoint,
    InterestResult,
    PtuState,
    Status,
    SurveyProgress,
)
from .requests import (
    REQUESTS,
    ArchiveGet,
    ArchiveList,
    ChooseTarget,
    Hello,
    PtuGoto,
    PtuHalt,
    PtuHome,
    PtuJog,
    PtuLook,
    ReleaseControl,
    Request,
    StreamRequest,
    SurveyCancel,
    SurveyStart,
    SurveyStatus,
    TakeControl,
)
from .settings import MAX_SETTINGS, check_setting

__all__ = [
    "MAX_SETTINGS",
    "MAX_TEXT",
    "MESSAGES",
    "REQUESTS",
    "RESULTS",
    "Ack",
    "ArchiveData",
    "ArchiveGet",
    "ArchiveList",
    "ArchiveListing",
    "Chip",
    "ChooseTarget",
    "Event",
    "FrameHeader",
    "FrameStream",
    "Hello",
    "InterestPoint",
    "InterestResult",
    "Message",
    "PtuGoto",
    "PtuHalt",
    "PtuHome",
    "PtuJog",
    "PtuLook",
    "PtuState",
    "ReleaseControl",
    "Request",
    "Status",
    "StreamRequest",
    "SurveyCancel",
    "SurveyProgress",
    "SurveyStart",
    "SurveyStatus",
    "TakeControl",
    "check_setting",
    "clip",
    "message_from",
]

MESSAGES: dict[str, type[Message]] = {
    m.KIND: m
    for m in (
        PtuGoto,
        PtuJog,
        PtuLook,
        PtuHalt,
        PtuHome,
        SurveyStart,
        SurveyCancel,
        SurveyStatus,
        ChooseTarget,
        TakeControl,
        ReleaseControl,
        ArchiveList,
        ArchiveGet,
        Ack,
        Hello,
        PtuState,
        SurveyProgress,
        InterestPoint,
        InterestResult,
        Event,
        FrameHeader,
        FrameStream,
        StreamRequest,
        Chip,
        Status,
        ArchiveListing,
        ArchiveData,
    )
}


def message_from(kind: str, body: dict[str, Any]) -> Message | None:
    """The message of a known kind; ``None`` for kinds this side does not know (ignored)."""
    cls = MESSAGES.get(kind)
    return None if cls is None else cls.from_body(body)
