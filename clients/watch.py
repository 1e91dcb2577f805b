"""What a client knows of one rig, folded from its telemetry into one state.

The keypad's screen and the operator's page are both views of a :class:`RigView`:
liveliness, the PTU, the survey's status and progress, the latest result with its
chips, and a short log of events and command outcomes. :class:`RigWatch` keeps it
current and wakes the view after each change; views coalesce bursts themselves.
"""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections import deque
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass, field

from cyborg.protocol.messages import (
    Ack,
    Chip,
    Event,
    InterestResult,
    Message,
    PtuState,
    Status,
    SurveyProgress,
    SurveyStatus,
)

from .rigclient import (
    ControlHeldError,
    RigClient,
    RigError,
    RigRefusedError,
    RigUnavailableError,
)

__all__ = ["LogLine", "Outcome", "RigView", "RigWatch"]

STATUS_PERIOD = 5.0
"""Seconds between status refreshes when nothing else prompts one."""


@dataclass(frozen=True)
class LogLine:
    at: float
    """Wall-clock seconds."""
    level: str
    """info, warning, error (from the rig) or ok, refused (a command's outcome)."""
    text: str


@dataclass(frozen=True)
class Outcome:
    """A command's outcome in plain words: an ack's result, or UNAVAILABLE, or ERROR."""

    ok: bool
    result: str
    detail: str


@dataclass
class RigView:
    alive: bool | None = None
    """None until the bus has said either way."""
    ptu: PtuState | None = None
    status: Status | None = None
    progress: SurveyProgress | None = None
    progress_at: float = 0.0
    """Monotonic time the progress arrived (its ETA counts down from there)."""
    result: InterestResult | None = None
    chips: dict[int, Chip] = field(default_factory=dict)
    log: deque[LogLine] = field(default_factory=lambda: deque(maxlen=100))

    @property
    def controller(self) -> str:
        if self.ptu is not None:
            return self.ptu.controller
        return self.status.controller if self.status else ""

    def eta(self) -> float | None:
        """Seconds left in the running station, counted down since the last progress."""
        p = self.progress
        if p is None or p.eta_s is None or p.stage in ("done", "failed", "incomplete"):
            return None
        return max(0.0, p.eta_s - (time.monotonic() - self.progress_at))


class RigWatch:
    def __init__(self, client: RigClient) -> None:
        self.client = client
        self.view = RigView()
        self.version = 0
        self._changed = asyncio.Event()
        self._refresh = asyncio.Event()

    def note(self, level: str, text: str) -> None:
        """Add a line to the log (command outcomes, client-side errors)."""
        self.view.log.append(LogLine(time.time(), level, text))
        self._bump()

    async def act(
        self,
        label: str,
        send: Callable[[], Awaitable[Ack]],
        *,
        motion: bool = True,
        take_hint: str = "take it over",
    ) -> Outcome:
        """Send one command as an interactive client does: take control first if nobody
        holds it (never from another client), and log the outcome in plain words."""
        try:
            mine = self.view.controller == self.client.name
            if motion and not mine and await self.client.ensure_control():
                self.note("ok", "took control (nobody held it)")
            ack = await send()
            outcome = Outcome(True, ack.result, ack.detail)
        except ControlHeldError as exc:
            outcome = Outcome(False, "REJECTED", f"{exc}; {take_hint}")
        except RigRefusedError as exc:
            outcome = Outcome(False, exc.ack.result, exc.ack.detail)
        except RigUnavailableError:
            outcome = Outcome(False, "UNAVAILABLE", "the rig does not answer")
        except (RigError, ValueError) as exc:
            outcome = Outcome(False, "ERROR", str(exc))
        finally:
            self.refresh()
        self.note("ok" if outcome.ok else "refused", f"{label}: {outcome.detail}")
        return outcome

    def refresh(self) -> None:
        """Ask for a status update soon (after a command that changes the rig's state)."""
        self._refresh.set()

    async def changes(self) -> AsyncIterator[int]:
        """Yield the version after each change; bursts coalesce into one wake-up."""
        seen = -1
        while True:
            if self.version == seen:
                self._changed.clear()
                await self._changed.wait()
            seen = self.version
            yield seen

    @contextlib.asynccontextmanager
    async def following(self) -> AsyncIterator[RigView]:
        """The view, kept current (:meth:`run` in a task) for the duration of the block."""
        task = asyncio.create_task(self.run(), name="cyborg.watch.run")
        try:
            yield self.view
        finally:
            task.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await task

    async def run(self) -> None:
        """Follow the rig until cancelled; survives the daemon leaving and coming back."""
        c = self.client
        feeds = [
            c.subscribe(c.keys.ptu_state, PtuState, maxsize=1),
            c.subscribe(c.keys.progress, SurveyProgress),
            c.subscribe(c.keys.result, InterestResult),
            c.subscribe(c.keys.chip, Chip, maxsize=3),
            c.subscribe(c.keys.events, Event),
        ]
        alive = c.alive()
        async with asyncio.TaskGroup() as tg:
            for feed in feeds:
                tg.create_task(self._follow(feed))
            tg.create_task(self._liveliness(alive))
            tg.create_task(self._statuses())

    async def _follow(self, feed: asyncio.Queue[Message]) -> None:
        while True:
            self.apply(await feed.get())

    async def _liveliness(self, alive: asyncio.Queue[bool]) -> None:
        while True:
            up = await alive.get()
            if up != self.view.alive:
                self.view.alive = up
                if self.view.log or not up:
                    self.note("info" if up else "error", "rig is up" if up else "rig went away")
                self._bump()
            if up:
                self.refresh()

    async def _statuses(self) -> None:
        while True:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(STATUS_PERIOD):  # not wait_for: see keypad._paint
                    await self._refresh.wait()
            self._refresh.clear()
            if self.view.alive is False:
                continue
            try:
                reply = await self.client.call(SurveyStatus(), timeout=2.0)
            except RigError:
                continue
            if isinstance(reply, Status):
                self.apply(reply)

    def apply(self, msg: Message) -> None:
        v = self.view
        if isinstance(msg, PtuState):
            v.ptu = msg
        elif isinstance(msg, Status):
            v.status = msg
            waiting = msg.result
            if waiting is not None and (v.result is None or v.result.station != waiting.station):
                v.result, v.chips = waiting, {}  # opened mid-station: the points it awaits
            elif waiting is None and v.result is not None and not _ahead(v.result, msg):
                v.result, v.chips = None, {}  # chosen, or a restarted rig: nothing awaits
        elif isinstance(msg, SurveyProgress):
            if v.progress is None or (v.progress.station, v.progress.stage) != (
                msg.station,
                msg.stage,
            ):
                self.refresh()
            v.progress, v.progress_at = msg, time.monotonic()
            if msg.stage in ("failed", "incomplete"):
                self.note("error", f"station {msg.station} {msg.stage}")
        elif isinstance(msg, InterestResult | Chip):
            # Chips come before their station's result; either one starts a new station.
            if any(chip.station != msg.station for chip in v.chips.values()):
                v.chips = {}
            if isinstance(msg, Chip):
                v.chips[msg.rank] = msg
            else:
                v.result = msg
        elif isinstance(msg, Event):
            v.log.append(LogLine(time.time(), msg.level, msg.text))
        else:
            return
        self._bump()

    def _bump(self) -> None:
        self.version += 1
        self._changed.set()


def _ahead(result: InterestResult, status: Status) -> bool:
    """Whether ``result`` came ahead of ``status``: taken while its station still ran."""
    return status.state == "surveying" and status.station == result.station
