"""The live views' clock: which views are due, and how long the frame loop may sleep."""

from __future__ import annotations

import pytest

from cyborg.daemon.liveview import LiveViews
from cyborg.protocol.keys import Keys
from cyborg.protocol.messages import StreamRequest

CAP = 0.2


def _views(watched: set[str]) -> LiveViews:
    return LiveViews(Keys("rig"), rate=10.0, quality=70, watched=lambda key: key in watched)


def test_unwatched_views_never_wake_the_loop_early() -> None:
    """Nobody watches: nothing is due and the loop sleeps the whole cap, however long ago
    the views were last due (their next time lies in the past)."""
    views = _views(set())
    views.ask(StreamRequest(fps=5.0, width=320, quality=50))
    for now in (0.0, 100.0, 100.001, 250.0):
        assert views.due(now) == []
        assert views.next_wake(now, cap=CAP) == pytest.approx(CAP)


def test_a_watched_view_sets_the_wake_and_stops_when_unwatched() -> None:
    watched: set[str] = set()
    views = _views(watched)
    watched.add(views.keys.frame)
    due = views.due(10.0)
    assert [v.key for v in due] == [views.keys.frame]
    assert views.next_wake(10.0, cap=CAP) == pytest.approx(0.1)  # 10 fps
    assert views.next_wake(10.05, cap=CAP) < 0.1
    watched.clear()  # the viewer left: back to the cap, not a spin on a past due time
    assert views.due(20.0) == []
    assert views.next_wake(20.0, cap=CAP) == pytest.approx(CAP)


def test_only_watched_streams_count() -> None:
    """A slow watched stream sets the wake; a fast unwatched one does not."""
    views = _views(set())
    fast = views.ask(StreamRequest(fps=30.0, width=160, quality=40))
    slow = views.ask(StreamRequest(fps=1.0, width=160, quality=40))
    views.watched = lambda key: key == slow.key
    assert [v.key for v in views.due(5.0)] == [slow.key]
    assert views.next_wake(5.0, cap=2.0) == pytest.approx(1.0)
    assert fast.key in views.streams
