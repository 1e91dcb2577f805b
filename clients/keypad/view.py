"""The keypad's screen as text: a pure function of what the client knows, so it is
tested without a terminal and the curses layer only paints lines."""

from __future__ import annotations

import itertools
import textwrap
import time
from dataclasses import dataclass, field

from cyborg.clients.watch import RigView
from cyborg.protocol.aims import EXCLUSIONS, KINDS, Aim

__all__ = ["ASIDE", "KEYS", "STEPS", "Line", "Prompt", "progress_fraction", "render"]

STEPS = (0.1, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0)
"""Jog step sizes in degrees, cycled with + and -."""

KEYS = (
    "←↑↓→ jog  +/- step  h home  SPACE halt  s survey  c cancel  a aim  x aside",
    "1/2/3 choose  0 none  p+1..3 look at  t take  r release  q quit",
)

ASIDE: tuple[frozenset[str], ...] = tuple(
    frozenset(names)
    for size in range(len(EXCLUSIONS) + 1)
    for names in itertools.combinations(EXCLUSIONS, size)
)
"""What ``x`` cycles through: nothing set aside, each exclusion, then their combinations."""

Line = tuple[str, str]
"""(text, style): style is one of title, alert, ok, warn, dim, normal."""

_LEVEL_STYLE = {"error": "alert", "refused": "alert", "warning": "warn", "ok": "ok"}


@dataclass
class Prompt:
    """The keypad's own state: who it is, where it dials, and the keys half typed."""

    rig: str
    name: str
    endpoints: str
    step: float = 2.0
    prefix: str = ""
    kind: str | None = None
    """The kind the next station seeks (``a`` cycles it); None: whatever the rig would take."""
    aside: frozenset[str] = field(default_factory=frozenset)
    """The kinds the next station sets aside (``x`` cycles them)."""

    @property
    def aim(self) -> str | None:
        """The aim the next survey asks for; None leaves it to the rig (its status says which).

        >>> p = Prompt("rig1", "me", "")
        >>> p.aim, p.next_kind().next_kind().aim, p.next_aside().aim
        (None, 'dark', 'dark+no-vegetation')
        """
        if self.kind is None and not self.aside:
            return None
        return Aim(self.kind or "any", self.aside).text

    def next_kind(self) -> Prompt:
        """The next kind: the rig's, then each of ``protocol.aims.KINDS`` in turn."""
        cycle: list[str | None] = [None, *KINDS]
        self.kind = cycle[(cycle.index(self.kind) + 1) % len(cycle)]
        return self

    def next_aside(self) -> Prompt:
        """The next set of exclusions (:data:`ASIDE`)."""
        self.aside = ASIDE[(ASIDE.index(self.aside) + 1) % len(ASIDE)]
        return self


def progress_fraction(stage: str, done: int, total: int) -> float:
    """One bar across the stages: tiles 60 %, analysis to 80 %, chips the rest."""
    part = done / total if total else 0.0
    return {
        "tiles": 0.6 * part,
        "analysis": 0.6,
        "chips": 0.8 + 0.2 * part,
        "done": 1.0,
    }.get(stage, 0.0)


def _header(view: RigView, prompt: Prompt) -> list[Line]:
    if view.alive:
        holder = view.controller
        who = "you" if holder == prompt.name else holder or "nobody"
        title = f" CYBORG KEYPAD  rig {prompt.rig}  ● UP  control: {who}"
        lines: list[Line] = [(title, "title")]
    else:
        state = "not seen yet" if view.alive is None else "DOWN"
        lines = [
            (f" CYBORG KEYPAD  rig {prompt.rig}  ○ {state}, waiting on {prompt.endpoints}", "alert")
        ]
    ptu = view.ptu
    if ptu is None:
        lines.append((" PTU  no state yet", "dim"))
    elif not view.alive:  # the last word of a rig that is gone: shown as such
        lines.append((f" PTU  pan {ptu.pan:+8.2f}°  tilt {ptu.tilt:+7.2f}°  STALE", "dim"))
    else:
        motion = "MOVING" if ptu.moving else "still"
        link = "" if ptu.link == "ready" else f"  link {ptu.link.upper()}"
        lines.append(
            (
                f" PTU  pan {ptu.pan:+8.2f}°  tilt {ptu.tilt:+7.2f}°  {motion:6}{link}"
                f"   jog step {prompt.step:g}°",
                "alert" if link else "normal",
            )
        )
    s = view.status
    if s is None:
        lines.append((" rig  status unknown", "dim"))
    else:
        where = f"  station {s.station}  {s.distance_m:g} m" if s.station else ""
        lines.append((f" rig  {s.state}{where}", "normal"))
    lines.append(_aim(view, prompt))
    return lines


def _aim(view: RigView, prompt: Prompt) -> Line:
    """What the next station will seek: the keypad's choice, else the rig's (its status)."""
    keys = "(a: kind, x: set aside)"
    if prompt.aim is not None:
        return (f" aim  next station: {prompt.aim}, this keypad's {keys}", "warn")
    rigs = view.status.aim if view.status else ""
    return (f" aim  next station: {rigs + ', ' if rigs else ''}the rig's {keys}", "normal")


def _progress(view: RigView, width: int) -> list[Line]:
    p = view.progress
    if p is None and view.result is not None:  # opened while a station's points wait
        r = view.result
        keys = "".join(f"{q.rank}/" for q in r.points if q.target)
        return [(f" survey  points of {r.station} await a choice: {keys}0", "warn")]
    if p is None:
        return [(" survey  none yet: press s", "dim")]
    fraction = progress_fraction(p.stage, p.done, p.total)
    count = f" {p.done}/{p.total}" if p.total and p.stage in ("tiles", "chips") else ""
    eta = view.eta()
    tail = f"{p.stage}{count}" + (f"  ETA {eta:.0f} s" if eta is not None else "")
    bar_width = max(10, width - 12 - len(tail) - 4)
    filled = round(fraction * bar_width)
    style = "alert" if p.stage in ("failed", "incomplete") else "normal"
    return [(f" survey [{'#' * filled}{'.' * (bar_width - filled)}] {tail}", style)]


def _points(view: RigView, width: int) -> list[Line]:
    r = view.result
    if r is None:
        return []
    sought = f" (aim {r.aim})" if r.aim else ""
    lines: list[Line] = [(f" Interest points of {r.station}{sought}:", "title")]
    if not r.points:
        lines.append(("   none found", "dim"))
    for p in r.points:
        chip = "  chip ✓" if p.rank in view.chips else ""
        style = "ok" if p.rank == 1 else "normal"
        if not p.target:
            chip, style = "  no further target", "dim"
        lines.append(
            (
                f"  #{p.rank}  score {p.score:6.2f}  pan {p.pan:+8.2f}°  "
                f"tilt {p.tilt:+7.2f}°{chip}",
                style,
            )
        )
        why = textwrap.wrap(p.why or "-", width - 7)[:2]
        lines.extend((f"      {w}", "dim") for w in why)
    return lines


def _log(view: RigView, rows: int, width: int) -> list[Line]:
    """The newest entries that fit, each wrapped (continuation lines indented under the
    text), so a long reason or error is read whole, not cut at the screen's edge."""
    if rows <= 0:
        return []
    lines: list[Line] = []
    for entry in view.log:
        stamp = time.strftime("%H:%M:%S", time.localtime(entry.at))
        style = _LEVEL_STYLE.get(entry.level, "normal")
        wrapped = textwrap.wrap(
            entry.text, width - 11, subsequent_indent="", break_long_words=True
        ) or [""]
        lines.append((f" {stamp} {wrapped[0]}", style))
        lines.extend((f"          {more}", style) for more in wrapped[1:])
    return lines[-rows:]


def render(view: RigView, prompt: Prompt, width: int = 80, height: int = 24) -> list[Line]:
    """Exactly ``height`` lines, none wider than ``width - 1`` (curses cannot write the
    bottom-right cell)."""
    top = [*_header(view, prompt), ("", "normal"), *_progress(view, width), ("", "normal")]
    points = _points(view, width)
    keys: list[Line] = [(f" {k}", "dim") for k in KEYS]
    if prompt.prefix:
        keys[0] = (" look at which point? press 1, 2 or 3 (any other key cancels)", "warn")
    room = height - len(top) - len(keys) - 1
    points = points[: max(0, room - 1)]
    log = _log(view, room - len(points), width)
    body = [*top, *points, *([("", "normal")] * (room - len(points) - len(log))), *log]
    lines = [*body, ("", "normal"), *keys][:height]
    return [(text[: width - 1], style) for text, style in lines]
