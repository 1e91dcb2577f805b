"""The session log's writer on its own: it never blocks the caller, and a full disk stops
the log, not the rig."""

from __future__ import annotations

from pathlib import Path

from cyborg.clients.replay import read_log
from cyborg.daemon.record import SessionLog


def test_a_full_disk_stops_the_log_and_nothing_else(small_disk: Path) -> None:
    log = SessionLog(small_disk / "session.mcap", {"rig": "t"}, queue_size=8)
    blob = b'{"data": "' + b"x" * 500_000 + b'"}'
    for i in range(20):  # 10 MB into 3 MiB
        log.put(("/t", "cyborg.t", i, blob))
    log.close()
    assert "No space left" in log.failed
    metadata, messages = read_log(small_disk / "session.mcap")
    assert metadata["session"] == {"rig": "t"}
    assert all(m.data == blob for m in messages)


def test_the_log_reads_back_in_order_and_counts_what_it_dropped(tmp_path: Path) -> None:
    log = SessionLog(tmp_path / "session.mcap", {"rig": "t"})
    for i in range(1000):
        log.put(("/a" if i % 2 else "/b", "cyborg.t", i, b'{"i": %d}' % i))
    log.close()
    _, messages = read_log(tmp_path / "session.mcap")
    times = [m.log_time for m in messages]
    assert times == sorted(times) and len(times) + log.dropped == 1000  # dropped, not waited
    assert {m.topic for m in messages} == {"/a", "/b"}
