"""The keypad's loop: curses reads keys and paints lines; :class:`~clients.watch.RigWatch`
follows the rig; every command runs in its own task, so HALT never waits behind another
command and a rig that went away only delays the key that needed it.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import curses
import locale
import os
import sys
from collections.abc import Awaitable, Callable

from cyborg.protocol.messages import (
    Ack,
    ChooseTarget,
    PtuGoto,
    PtuHalt,
    PtuHome,
    PtuJog,
    ReleaseControl,
    SurveyCancel,
    SurveyStart,
    TakeControl,
)

from ..link import transport
from ..rigclient import RigClient
from ..watch import RigWatch
from .view import STEPS, Prompt, render

__all__ = ["run_keypad"]

_ARROWS = {
    curses.KEY_LEFT: (-1, 0),
    curses.KEY_RIGHT: (1, 0),
    curses.KEY_UP: (0, 1),
    curses.KEY_DOWN: (0, -1),
}
_ASCII = str.maketrans(
    {"←": "<", "→": ">", "↑": "^", "↓": "v", "●": "*", "○": "o", "°": "", "✓": "ok"}
)
_PAINT_PERIOD = 0.5
"""Seconds between repaints when nothing changes (the ETA counts down)."""


class Keypad:
    def __init__(self, client: RigClient, prompt: Prompt) -> None:
        self.client = client
        self.watch = RigWatch(client)
        self.prompt = prompt
        self._tasks: set[asyncio.Task] = set()
        self._dirty = asyncio.Event()

    # -- keys ------------------------------------------------------------------------------

    def key(self, ch: int) -> bool:
        """Act on one key; False means quit."""
        self._dirty.set()
        if ch == ord(" "):  # first, always: halt needs no control and never waits
            self.prompt.prefix = ""
            self._spawn("halt", lambda: self.client.command(PtuHalt()), motion=False)
            return True
        if self.prompt.prefix:
            self.prompt.prefix = ""
            if ch in (ord("1"), ord("2"), ord("3")):
                self._look(ch - ord("0"))
            return True
        if ch in _ARROWS:
            dp, dt = _ARROWS[ch]
            step = self.prompt.step
            self._spawn("jog", lambda: self.client.command(PtuJog(dp * step, dt * step)))
        elif ch in (ord("+"), ord("=")):
            self._step(+1)
        elif ch in (ord("-"), ord("_")):
            self._step(-1)
        elif ch == ord("h"):
            self._spawn("home", lambda: self.client.command(PtuHome()))
        elif ch == ord("s"):
            start = SurveyStart(aim=self.prompt.aim)
            self._spawn("survey", lambda: self.client.command(start))
        elif ch == ord("a"):
            self.prompt.next_kind()
        elif ch == ord("x"):
            self.prompt.next_aside()
        elif ch == ord("c"):
            self._spawn("cancel", lambda: self.client.command(SurveyCancel()))
        elif ch in (ord("0"), ord("1"), ord("2"), ord("3")):
            self._choose(ch - ord("0"))
        elif ch == ord("p"):
            self.prompt.prefix = "p"
        elif ch == ord("t"):
            take = TakeControl()
            self._spawn("take", lambda: self.client.command(take), motion=False)
        elif ch == ord("r"):
            release = ReleaseControl()
            self._spawn("release", lambda: self.client.command(release), motion=False)
        elif ch in (ord("q"), ord("Q")):
            return False
        return True

    def _step(self, direction: int) -> None:
        i = min(range(len(STEPS)), key=lambda k: abs(STEPS[k] - self.prompt.step))
        self.prompt.step = STEPS[max(0, min(len(STEPS) - 1, i + direction))]

    def _choose(self, rank: int) -> None:
        result = self.watch.view.result
        if result is None:
            self.watch.note("refused", "choose: no station awaits a choice (press s to survey)")
            return
        point = next((p for p in result.points if p.rank == rank), None)
        if point is not None and not point.target:
            self.watch.note("refused", f"choose: #{rank} is no further target (0: none)")
            return
        msg = ChooseTarget(result.station, rank)
        self._spawn(f"choose #{rank}", lambda: self.client.command(msg))

    def _look(self, rank: int) -> None:
        result = self.watch.view.result
        point = next((p for p in result.points if p.rank == rank), None) if result else None
        if point is None:
            self.watch.note("refused", f"look: there is no point #{rank}")
            return
        msg = PtuGoto(point.pan, point.tilt)
        self._spawn(f"look at #{rank}", lambda: self.client.command(msg))

    # -- commands --------------------------------------------------------------------------

    def _spawn(self, label: str, send: Callable[[], Awaitable[Ack]], motion: bool = True) -> None:
        """Each command in its own task: HALT never waits behind another."""
        act = self.watch.act(label, send, motion=motion, take_hint="press t to take it over")
        task = asyncio.create_task(act)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    # -- screen ----------------------------------------------------------------------------

    async def run(self, screen: curses.window) -> None:
        loop = asyncio.get_running_loop()
        keys: asyncio.Queue[int] = asyncio.Queue()

        def readable() -> None:
            while (ch := screen.getch()) != -1:
                keys.put_nowait(ch)

        loop.add_reader(sys.stdin.fileno(), readable)
        background = [
            asyncio.create_task(self.watch.run()),
            asyncio.create_task(self._paint(screen)),
            asyncio.create_task(self._wake_on_change()),
        ]
        try:
            while self.key(await keys.get()):
                pass
        finally:
            loop.remove_reader(sys.stdin.fileno())
            for task in [*background, *self._tasks]:
                task.cancel()
            await asyncio.gather(*background, *self._tasks, return_exceptions=True)

    async def _wake_on_change(self) -> None:
        async for _ in self.watch.changes():
            self._dirty.set()

    async def _paint(self, screen: curses.window) -> None:
        styles = _styles()
        unicode = _shows_unicode(screen.encoding)
        while True:
            height, width = screen.getmaxyx()
            screen.erase()
            for y, (line, style) in enumerate(render(self.watch.view, self.prompt, width, height)):
                text = line if unicode else line.translate(_ASCII)
                with contextlib.suppress(curses.error):  # a terminal shrunk mid-paint
                    screen.addnstr(y, 0, text, width - 1, styles[style])
            screen.refresh()
            # asyncio.timeout, not wait_for: 3.11's wait_for can swallow a cancellation
            # that lands as its timeout fires, and the keypad would never quit.
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(_PAINT_PERIOD):
                    await self._dirty.wait()
            self._dirty.clear()
            await asyncio.sleep(0.03)  # let a burst of telemetry land in one paint


def _shows_unicode(encoding: str) -> bool:
    """Whether curses can write the arrows and marks in the terminal's encoding. Asked of
    the screen, not of Python: under a C locale Python speaks UTF-8 while curses, in
    ASCII, would paint them blank."""
    try:
        "".join(map(chr, _ASCII)).encode(encoding)
    except (UnicodeEncodeError, LookupError):
        return False
    return True


def _styles() -> dict[str, int]:
    colours = {"alert": curses.COLOR_RED, "ok": curses.COLOR_GREEN, "warn": curses.COLOR_YELLOW}
    styles = {"normal": curses.A_NORMAL, "dim": curses.A_DIM, "title": curses.A_REVERSE}
    for i, (name, colour) in enumerate(colours.items(), start=1):
        attr = curses.A_BOLD
        if curses.has_colors():
            curses.init_pair(i, colour, -1)
            attr |= curses.color_pair(i)
        styles[name] = attr
    return styles


def _session(screen: curses.window, args: argparse.Namespace) -> None:
    curses.curs_set(0) if curses.tigetstr("civis") else None
    if curses.has_colors():
        curses.use_default_colors()
    screen.nodelay(True)
    screen.keypad(True)
    link = transport(args, "peer")
    prompt = Prompt(args.rig, args.name, ", ".join(link.connect))

    async def main() -> None:
        with RigClient.open(link, args.rig, args.name) as client:
            await Keypad(client, prompt).run(screen)

    asyncio.run(main())


def run_keypad(args: argparse.Namespace) -> int:
    if not (sys.stdin.isatty() and sys.stdout.isatty()):
        print("cyborg keypad: needs a terminal (run it in one, or use the script commands)")
        return 2
    locale.setlocale(locale.LC_ALL, "")
    os.environ.setdefault("ESCDELAY", "25")  # a lone Esc should not stall the arrows
    try:
        curses.wrapper(_session, args)
    except curses.error as exc:
        print(f"cyborg keypad: this terminal cannot run it (TERM={os.environ.get('TERM')}): {exc}")
        return 2
    except KeyboardInterrupt:
        pass
    return 0
