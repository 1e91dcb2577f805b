"""The keypad's screen as text: fits 80×24 in every state, says what matters plainly."""

from __future__ import annotations

import time

import pytest

from cyborg.clients.keypad.view import Prompt, progress_fraction, render
from cyborg.clients.watch import LogLine, RigView
from cyborg.protocol.messages import (
    Chip,
    InterestPoint,
    InterestResult,
    PtuState,
    Status,
    SurveyProgress,
)

PROMPT = Prompt("rig1", "keypad-me", "tcp/127.0.0.1:7447")


def _busy_view() -> RigView:
    why = "H class 5/6 (109.7deg, 0.091% of image) +7.0; " * 4
    points = tuple(InterestPoint(r, 10.0 * r, 5.0, 7.0 - r, -20.0 + r, 8.5, why) for r in (1, 2, 3))
    view = RigView(
        alive=True,
        ptu=PtuState(12.3456, -3.21, True, "ready", "keypad-me"),
        status=Status("surveying", "s", "20261121-101500/st01-300m", 300.0, "keypad-me"),
        progress=SurveyProgress("20261121-101500/st01-300m", "tiles", 3, 6, 12.0),
        progress_at=time.monotonic(),
        result=InterestResult("20261121-101500/st01-300m", points, 540, 288),
    )
    view.chips[1] = Chip("20261121-101500/st01-300m", 1, 1.0, 2.0, "chips/1.png")
    for i in range(30):
        view.log.append(LogLine(time.time(), "refused" if i % 2 else "ok", f"line {i} " * 20))
    return view


@pytest.mark.parametrize("view", [RigView(), RigView(alive=False), _busy_view()])
@pytest.mark.parametrize("size", [(80, 24), (60, 16), (132, 43)])
def test_every_state_fits_the_screen(view: RigView, size: tuple[int, int]) -> None:
    width, height = size
    lines = render(view, PROMPT, width, height)
    assert len(lines) == height
    assert all(len(text) < width for text, _ in lines)
    assert lines[-1][0].strip().startswith("1/2/3 choose")  # the keys are always shown


def test_a_busy_screen_shows_pose_control_progress_points_and_the_latest_log() -> None:
    text = "\n".join(t for t, _ in render(_busy_view(), PROMPT))
    assert "● UP  control: you" in text
    assert "pan   +12.35°  tilt   -3.21°  MOVING" in text
    assert "station 20261121-101500/st01-300m  300 m" in text
    assert "tiles 3/6  ETA 12 s" in text
    assert "#1  score   6.00" in text and "chip ✓" in text and "#3  score" in text
    assert "line 29" in text and "line 0 " not in text  # newest log lines win the space


def test_a_down_rig_is_plain_and_alerting() -> None:
    lines = render(RigView(alive=False), PROMPT)
    assert "○ DOWN, waiting on tcp/127.0.0.1:7447" in lines[0][0]
    assert lines[0][1] == "alert"
    failed = RigView(alive=True, progress=SurveyProgress("x/st01", "failed"))
    assert any(style == "alert" and "failed" in t for t, style in render(failed, PROMPT))


def test_the_look_prefix_asks_which_point() -> None:
    lines = render(RigView(), Prompt("rig1", "me", "ep", prefix="p"))
    assert "look at which point? press 1, 2 or 3" in lines[-2][0]


def test_progress_runs_through_the_stages_monotonically() -> None:
    steps = [("tiles", k, 6) for k in range(7)] + [("analysis", 0, 0)]
    steps += [("chips", k, 3) for k in range(4)] + [("done", 0, 0)]
    fractions = [progress_fraction(*s) for s in steps]
    assert fractions == sorted(fractions) and fractions[0] == 0 and fractions[-1] == 1


def test_long_log_lines_wrap_and_a_gone_rig_shows_its_pose_as_stale() -> None:
    view = RigView(alive=True)
    long = "station 20261121-101500/st01-300m failed: " + "the PTU did not answer " * 5
    view.log.append(LogLine(time.time(), "error", long))
    lines = [t for t, _ in render(view, PROMPT)]
    text = " ".join(t.strip() for t in lines)
    assert "did not answer the PTU did not answer" in text  # nothing cut at the edge
    assert sum("the PTU did not answer" in t for t in lines) >= 2
    view.ptu = PtuState(12.0, -3.0, False)
    view.alive = False
    (ptu_line,) = [(t, s) for t, s in render(view, PROMPT) if t.startswith(" PTU")]
    assert "STALE" in ptu_line[0] and ptu_line[1] == "dim"
