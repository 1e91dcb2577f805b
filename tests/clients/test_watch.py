"""RigWatch folds telemetry into one view: chips and results of one station stay together."""

from __future__ import annotations

from cyborg.clients.watch import RigWatch
from cyborg.protocol.messages import Chip, Event, InterestResult, SurveyProgress


async def test_chips_arrive_before_their_result_and_a_new_station_starts_afresh() -> None:
    watch = RigWatch(client=None)  # apply() only folds messages; no bus needed
    for rank in (1, 2, 3):
        watch.apply(Chip("s/st01", rank, 0.0, 0.0, f"chips/{rank}.png"))
    watch.apply(InterestResult("s/st01"))
    assert sorted(watch.view.chips) == [1, 2, 3] and watch.view.result.station == "s/st01"
    watch.apply(Chip("s/st02", 1, 0.0, 0.0, "chips/1.png"))
    assert list(watch.view.chips) == [1] and watch.view.chips[1].station == "s/st02"


async def test_failures_and_events_reach_the_log_and_each_change_bumps_the_version() -> None:
    watch = RigWatch(client=None)
    v0 = watch.version
    watch.apply(SurveyProgress("s/st01", "tiles", 1, 6, 10.0))
    assert 9.0 < watch.view.eta() <= 10.0
    watch.apply(SurveyProgress("s/st01", "failed"))
    watch.apply(Event("warning", "worker restarted"))
    assert watch.view.eta() is None
    assert [(e.level, e.text) for e in watch.view.log] == [
        ("error", "station s/st01 failed"),
        ("warning", "worker restarted"),
    ]
    assert watch.version > v0
