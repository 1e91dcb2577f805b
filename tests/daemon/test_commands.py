"""The command handler in-process: identity, control, malformed input and motion, on the
emulated PTU with a real worker (the bus is only its transport, tested apart)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cyborg.daemon.archive import Archive
from cyborg.daemon.camera import open_camera
from cyborg.daemon.commands import Commands
from cyborg.daemon.config import SurveyConfig
from cyborg.daemon.liveview import LiveViews
from cyborg.daemon.ptu import open_ptu
from cyborg.daemon.rig import Rig
from cyborg.daemon.survey import Survey, SurveyTelemetry
from cyborg.daemon.worker import VisionWorker
from cyborg.protocol.envelope import MAX_MESSAGE, decode, encode
from cyborg.protocol.keys import Keys
from cyborg.protocol.messages import (
    Ack,
    Hello,
    Message,
    PtuGoto,
    PtuHalt,
    SurveyStatus,
    TakeControl,
    message_from,
)
from cyborg.protocol.version import PROTOCOL_MAJOR, PROTOCOL_MINOR

pytestmark = pytest.mark.timeout(120)


def _envelope(msg: Message, corr: str | None = None) -> bytes:
    return encode(msg.KIND, msg.to_body(), src="cyborgd", corr=corr)


@pytest.fixture
async def commands(tmp_path: Path):
    ptu = open_ptu("emu://?time_scale=50")
    rig = Rig(ptu, lambda pose: open_camera("sim://outcrop?seed=3", pose=pose))
    events: list[tuple[str, str]] = []
    async with VisionWorker() as worker:
        await ptu.open()
        archive = Archive(tmp_path / "archive", "t")
        archive.open()
        telemetry = SurveyTelemetry(
            lambda m: None, lambda m: None, lambda m: None, lambda *e: events.append(e)
        )
        survey = Survey(rig, worker, archive, SurveyConfig(), hfov=30.0, telemetry=telemetry)
        handler = Commands(
            rig,
            survey,
            archive,
            worker,
            rig_name="t",
            encode=_envelope,
            announce=lambda level, text: events.append((level, text)),
            max_reply=MAX_MESSAGE - 4096,
            views=LiveViews(Keys("t"), 0.0, 70, lambda key: False),
        )
        try:
            yield handler, events
        finally:
            await survey.cancel("test over")
            await ptu.close()


async def _ask(handler: Commands, client: str, msg: Message, src: str | None = None) -> Message:
    payload = encode(msg.KIND, msg.to_body(), src=src or client, corr="c1")
    env = decode(await handler.handle(client, msg.VERB, payload))
    assert env.corr == "c1"  # the reply is tied to its request
    return message_from(env.kind, env.body)


async def test_motion_needs_control_and_halt_needs_none(commands) -> None:
    handler, events = commands
    hello = await _ask(handler, "alice", Hello(PROTOCOL_MAJOR, PROTOCOL_MINOR))
    assert isinstance(hello, Hello) and hello.rig == "t"
    refused = await _ask(handler, "alice", PtuGoto(5.0, -2.0))
    assert isinstance(refused, Ack) and refused.result == "REJECTED" and "control" in refused.detail
    assert (await _ask(handler, "alice", TakeControl())).ok
    assert any("alice" in text for _, text in events)  # the change of controller is announced
    assert (await _ask(handler, "alice", PtuGoto(5.0, -2.0))).ok
    assert (await _ask(handler, "bob", PtuGoto(0.0, 0.0))).result == "REJECTED"
    assert (await _ask(handler, "bob", PtuHalt())).ok  # anyone may stop the head
    limit = await _ask(handler, "alice", PtuGoto(200.0, 0.0))
    assert limit.result == "LIMIT" and limit.detail.startswith("ptu/goto: pan 200.000 deg")
    assert "PP" not in limit.detail  # the unit's command code is for the log


async def test_forged_identity_and_malformed_requests_are_refused(commands) -> None:
    handler, _ = commands
    forged = await _ask(handler, "mallory", TakeControl(), src="alice")
    assert forged.result == "REJECTED" and "speaks only for itself" in forged.detail
    for verb, payload in (
        ("ptu/goto", b"\xc1 not msgpack"),
        ("ptu/goto", encode("ptu.halt", {}, src="alice")),
        ("no/such/verb", encode("hello", {}, src="alice")),
    ):
        env = decode(await handler.handle("alice", verb, payload))
        reply = message_from(env.kind, env.body)
        assert isinstance(reply, Ack) and reply.result == "ERROR", verb


async def test_the_status_carries_the_unit_s_own_position_step(commands) -> None:
    """2.3: read from the unit at connect (a D46-17: 185.1428 arc-seconds a position)."""
    handler, _ = commands
    status = await _ask(handler, "alice", SurveyStatus())
    assert status.ptu_step == pytest.approx(185.1428 / 3600, rel=1e-4)
