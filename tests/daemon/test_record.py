"""The session log's writer and recorder on their own: the writer never blocks the caller,
a full disk stops the log, not the rig; the recorder reads what the bus does not carry
(where a station stood, why it ended) from the archive."""

from __future__ import annotations

from pathlib import Path

from cyborg.clients.replay import read_log
from cyborg.daemon.archive import Archive
from cyborg.daemon.record import FILENAME, Recorder, SessionLog
from cyborg.protocol import recording as rec
from cyborg.protocol.messages import SurveyProgress
from tests.integration.logcheck import Checked


def test_a_full_disk_stops_the_log_and_nothing_else(small_disk: Path) -> None:
    log = SessionLog(small_disk / "session.mcap", {"rig": "t"}, queue_size=8)
    blob = b'{"data": "' + b"x" * 500_000 + b'"}'
    for i in range(20):  # 10 MB into 3 MiB
        log.put(("/t", "cyborg.event", i, blob))
    log.close()
    assert "No space left" in log.failed
    metadata, messages = read_log(small_disk / "session.mcap")
    assert metadata["session"] == {"rig": "t"}
    assert all(m.data == blob for m in messages)


def test_the_log_reads_back_in_order_and_counts_what_it_dropped(tmp_path: Path) -> None:
    log = SessionLog(tmp_path / "session.mcap", {"rig": "t"})
    for i in range(1000):
        log.put(("/a" if i % 2 else "/b", "cyborg.event", i, b'{"i": %d}' % i))
    log.close()
    _, messages = read_log(tmp_path / "session.mcap")
    times = [m.log_time for m in messages]
    assert times == sorted(times) and len(times) + log.dropped == 1000  # dropped, not waited
    assert {m.topic for m in messages} == {"/a", "/b"}


def test_the_recorder_places_each_station_and_says_why_one_ended(tmp_path: Path) -> None:
    """From the stations' manifests, as the daemon's archive writes them: a LocationFix per
    station it can place, the first station's site as the file's metadata, and a station
    left incomplete in /log with its reason."""
    archive = Archive(tmp_path)
    archive.open()
    session = archive.new_session()
    site = {"name": "cliff", "latitude": 40.331, "longitude": -3.517, "altitude": 612.5}
    placed = archive.new_station(session, 1, 300, site=site | {"source": "config"})
    lost = archive.new_station(session, 2, 60, site={"latitude": None, "source": "unknown"})
    lost.finish("incomplete", "halted by alice")
    recorder = Recorder(tmp_path, {"rig": "t"}, frame_rate=0)
    for station in (placed, lost):
        stage = "tiles" if station is placed else "incomplete"
        recorder.message(SurveyProgress(f"{session}/{station.name}", stage))
    recorder.close()
    log = Checked(tmp_path / session / FILENAME)
    (fix,) = log.on(rec.LOCATION)
    assert (fix["latitude"], fix["longitude"], fix["altitude"]) == (40.331, -3.517, 612.5)
    assert log.metadata["site"] == {"station": f"{session}/st01-300m"} | rec.site_metadata(
        site | {"source": "config"}
    )
    (said,) = [doc["message"] for doc in log.on(rec.LOG)]
    assert said == f"station {session}/st02-60m incomplete: halted by alice"
