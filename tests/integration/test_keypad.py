"""``cyborg keypad`` in a real pseudo-terminal (80×24, read back through the pyte terminal
emulator) against a real daemon: jog, survey, look, choose, control, halt, restarts."""

from __future__ import annotations

import asyncio
import contextlib
import fcntl
import os
import pty
import re
import struct
import subprocess
import sys
import termios
from collections.abc import AsyncIterator

import pyte
import pytest

from cyborg.clients.rigclient import RigClient
from cyborg.protocol.messages import TakeControl

pytestmark = pytest.mark.timeout(180)

RIGHT, LEFT = b"\x1bOC", b"\x1bOD"  # xterm's arrows in keypad-transmit mode (curses sets it)


class Terminal:
    """A child process on a pty, its screen decoded by a terminal emulator."""

    def __init__(
        self, argv: list[str], rows: int = 24, cols: int = 80, locale: str = "C.UTF-8"
    ) -> None:
        master, slave = pty.openpty()
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", rows, cols, 0, 0))
        env = {**os.environ, "TERM": "xterm", "LANG": locale, "LC_ALL": locale}
        self.proc = subprocess.Popen(
            argv, stdin=slave, stdout=slave, stderr=slave, env=env, start_new_session=True
        )
        os.close(slave)
        os.set_blocking(master, False)
        self.fd = master
        self.screen = pyte.Screen(cols, rows)
        self.stream = pyte.ByteStream(self.screen)
        self.raw = bytearray()

    def pump(self) -> None:
        with contextlib.suppress(BlockingIOError, OSError):
            while chunk := os.read(self.fd, 65536):
                self.raw += chunk
                self.stream.feed(chunk)

    @property
    def text(self) -> str:
        self.pump()
        return "\n".join(self.screen.display)

    async def wait_for(self, pattern: str, timeout: float = 30.0) -> re.Match:
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while not (m := re.search(pattern, self.text)):
            if loop.time() > deadline:
                raise AssertionError(f"no {pattern!r} on the screen:\n{self.text}")
            await asyncio.sleep(0.05)
        return m

    async def wait_pose(self, pan: float, tilt: float | None = None, timeout: float = 30.0) -> None:
        """Until the PTU line shows the head still at (pan, tilt), within a unit step."""
        loop = asyncio.get_running_loop()
        deadline = loop.time() + timeout
        while True:
            m = re.search(r"PTU  pan\s+([+-][\d.]+)°  tilt\s+([+-][\d.]+)°  still", self.text)
            if (
                m
                and abs(float(m[1]) - pan) < 0.06
                and (tilt is None or abs(float(m[2]) - tilt) < 0.06)
            ):
                return
            if loop.time() > deadline:
                raise AssertionError(f"the head is not at {pan}, {tilt}:\n{self.text}")
            await asyncio.sleep(0.05)

    async def exit_status(self, timeout: float = 10.0) -> int:
        """Wait for the child to end, reading its output meanwhile (a full pty blocks it)."""
        async with asyncio.timeout(timeout):
            while self.proc.poll() is None:
                self.pump()
                await asyncio.sleep(0.05)
        return self.proc.returncode

    def press(self, keys: bytes) -> None:
        os.write(self.fd, keys)

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        os.close(self.fd)


@pytest.fixture
async def keypad(router: str) -> AsyncIterator[Terminal]:
    term = Terminal(
        [
            sys.executable,
            "-m",
            "cyborg.clients",
            "keypad",
            "--rig",
            "itest",
            "--connect",
            router,
            "--name",
            "arm",
        ]
    )
    yield term
    term.close()
    assert b"Traceback" not in term.raw, term.raw.decode(errors="replace")


async def test_keypad_drives_a_station(keypad: Terminal, daemon, other_client: RigClient) -> None:
    await keypad.wait_for("● UP  control: nobody")
    await keypad.wait_pose(0.0, 0.0)
    assert all(len(line.rstrip()) < 80 for line in keypad.screen.display)

    keypad.press(RIGHT)  # nobody held control: the first motion key takes it
    await keypad.wait_for("took control")
    await keypad.wait_pose(2.0, 0.0)
    await keypad.wait_for("control: you")
    keypad.press(b"+")
    await keypad.wait_for("jog step 5°")
    keypad.press(LEFT)
    await keypad.wait_pose(-3.0, 0.0)

    keypad.press(b"s")
    seen_tiles = False
    async with asyncio.timeout(90):
        while "Interest points of" not in keypad.text:
            seen_tiles |= bool(re.search(r"survey \[#*\.*\] tiles \d/6", keypad.text))
            await asyncio.sleep(0.05)
    assert seen_tiles
    await keypad.wait_for(r"survey \[#+\] done")
    best = await keypad.wait_for(r"#1  score\s+[\d.]+  pan\s+([+-][\d.]+)°  tilt\s+([+-][\d.]+)°")
    await keypad.wait_for(r"#3  score")
    assert re.search(r"\d % of the area", keypad.text)  # the why, in plain words

    keypad.press(b"p1")  # re-point at the best point
    await keypad.wait_pose(float(best[1]), float(best[2]))
    keypad.press(b"1")
    await keypad.wait_for(r"choose #1: .*60 m")

    # Someone else takes over: motion is refused plainly; halt still works for us.
    await other_client.command(TakeControl())
    await keypad.wait_for("control: intruder")
    keypad.press(RIGHT)
    await keypad.wait_for("control is held by intruder; press t to take it over")
    keypad.press(b" ")
    await keypad.wait_for("halt: halted")
    keypad.press(b"t")
    await keypad.wait_for("control: you")

    keypad.press(b"q")
    assert await keypad.exit_status() == 0


async def test_keypad_survives_the_daemon_going_away(keypad: Terminal, start_daemon) -> None:
    await keypad.wait_for("not seen yet, waiting on")  # started before the rig: it waits
    first = await start_daemon()
    await keypad.wait_for("● UP")
    keypad.press(RIGHT)
    await keypad.wait_pose(2.0)
    await first.stop()
    await keypad.wait_for("DOWN, waiting on")
    keypad.press(RIGHT)
    await keypad.wait_for("jog: the rig does not answer")
    await start_daemon()
    await keypad.wait_for("● UP")
    await keypad.wait_pose(0.0)  # a new emulator, back home
    await keypad.wait_for("control: nobody")  # control lived in the old daemon
    keypad.press(RIGHT)  # the new one is taken again
    await keypad.wait_pose(2.0)
    # The header reads the new daemon's own state: it says this keypad holds control there.
    # (Not counted in the log pane: curses scrolls it in place, and a terminal emulator
    # may show a pane repainted in parts.)
    await keypad.wait_for("control: you")
    keypad.press(b"q")
    assert await keypad.exit_status() == 0
