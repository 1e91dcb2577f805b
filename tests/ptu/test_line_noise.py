"""The real serial driver through line noise, lost replies and impossible positions: the
emulator on a pty (and over TCP), faults injected by the pty server.

A reply lost to the line is resynchronised and asked again when repeating the command is
harmless (queries, absolute moves), never for a relative move; a position outside the
limits the unit reported is asked again, then refused; a unit that is really gone still
fails the request.
"""

from __future__ import annotations

import asyncio
import logging

import pytest

from cyborg.daemon.ptu import (
    LinkState,
    PtuConnectionError,
    PtuProtocolError,
    PtuTimeoutError,
    PtyPtu,
)
from cyborg.daemon.ptu.ptyserver import NOISE, Fault
from cyborg.daemon.ptu.wire import match_reply

pytestmark = pytest.mark.timeout(60)


@pytest.mark.parametrize(
    "line",
    [
        "\ufffd\x1b~#\ufffd%\ufffd*\x7f\ufffd5\ufffd!* 1234",  # a burst glued in front
        "* 12\x1b\ufffd34",  # ...in the middle
        "* 12#%34",  # printable noise, digits either side
    ],
)
def test_noise_in_a_reply_is_never_a_number(line: str) -> None:
    assert match_reply(line, "PP", numeric=True) is None


def test_a_move_is_not_answered_by_a_query_reply() -> None:
    assert match_reply("* 1234", "PP500") is None
    assert match_reply("*", "PP500") is not None


async def test_noise_glued_onto_a_query_reply_is_retried(
    ptu: PtyPtu, caplog: pytest.LogCaptureFixture
) -> None:
    await ptu.move_to(20.0, 5.0)
    noise = Fault("noise", "PP")
    assert b"\n" not in noise.data and noise.data == NOISE  # glued: no line end of its own
    ptu.server.faults.append(noise)
    with caplog.at_level(logging.WARNING, "cyborg.daemon.ptu.serial"):
        here = await ptu.position()
    assert noise.fired == 1 and ptu.retried == 1
    assert here.pan_pos == ptu.server.emulator.pan.position
    assert "no readable reply to PP; line resynchronised, sending it again (1 of 2)" in caplog.text


async def test_noise_glued_onto_an_absolute_move_is_retried(ptu: PtyPtu) -> None:
    noise = Fault("noise", "TP")
    ptu.server.faults.append(noise)
    here = await ptu.move_to(10.0, -5.0)
    assert noise.fired == 1 and ptu.retried == 1
    assert (here.pan, here.tilt) == pytest.approx((10.0, -5.0), abs=0.026)


async def test_a_relative_move_is_never_sent_twice(ptu: PtyPtu) -> None:
    ptu.command_timeout = 0.3
    emu = ptu.server.emulator
    start = emu.pan.position
    noise = Fault("noise", "PO")
    ptu.server.faults.append(noise)
    with pytest.raises(PtuTimeoutError, match="no reply to PO100"):
        await ptu._do("PO", 100)
    assert noise.seen == 1 and ptu.retried == 0
    assert emu.pan.motion.target == start + 100  # moved once, not twice
    assert ptu.state is LinkState.READY
    assert (await ptu.position()).tilt_pos == emu.tilt.position


async def test_bursts_anywhere_on_the_line_never_give_a_wrong_position(ptu: PtyPtu) -> None:
    """Noise put on the line while the driver polls (some of it with a reply's first
    characters) lands between replies or glued onto them; every position read is still
    the unit's own."""
    emu = ptu.server.emulator
    await ptu.move_to(-30.0, 10.0)
    for k in range(30):
        ptu.server.inject(NOISE[k % 7 :] + b"* 31\r\n"[: k % 3])
        here = await ptu.position()
        assert (here.pan_pos, here.tilt_pos) == (emu.pan.position, emu.tilt.position)


async def test_an_impossible_position_is_asked_again(
    ptu: PtyPtu, caplog: pytest.LogCaptureFixture
) -> None:
    rewrite = Fault("rewrite", "PP")  # "* 99999": no D46 pan axis gets there
    ptu.server.faults.append(rewrite)
    with caplog.at_level(logging.WARNING, "cyborg.daemon.ptu.commanded"):
        here = await ptu.position()
    assert rewrite.fired == 1
    assert here.pan_pos == ptu.server.emulator.pan.position
    assert "PTU answered PP with 99999, outside -3090..3090" in caplog.text


async def test_an_impossible_position_is_never_returned(ptu: PtyPtu) -> None:
    before = await ptu.position()
    ptu.server.faults.append(Fault("rewrite", "TP", count=0, data=b"* -5000\r\n"))
    with pytest.raises(PtuProtocolError, match=r"outside -907\.\.604"):
        await ptu.position()
    assert ptu.last_position is before
    with pytest.raises(PtuProtocolError):
        await ptu.move_to(pan=5.0)  # sends no TP, but its motion wait reads the tilt


async def test_a_unit_that_answers_nothing_fails_without_retries(ptu: PtyPtu) -> None:
    ptu.command_timeout = 0.2
    ptu.server.faults.append(Fault("drop", count=0))
    with pytest.raises(PtuTimeoutError, match="the unit answers nothing"):
        await ptu.position()
    assert ptu.retried == 0


async def test_a_port_hung_up_for_long_still_fails(ptu: PtyPtu) -> None:
    ptu.server.hangup(30.0)
    with pytest.raises(PtuConnectionError):
        for _ in range(20):
            await ptu.position()
            await asyncio.sleep(0.01)
    assert ptu.state is LinkState.DISCONNECTED and ptu.retried == 0
