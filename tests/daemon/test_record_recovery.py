"""The session log survives a cut: what is queued reaches the disk in whole chunks without
waiting for more, and a log cut anywhere is recovered into a complete, indexed file that
the mcap library's ordinary reader and ``read_log`` (replay) read, holding every whole
chunk."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from cyborg.clients.replay import read_log
from cyborg.daemon.record import DAMAGED, SessionLog, recover, recover_logs

META = {"rig": "t", "camera": "v4l2://0"}


def _ordinary(path: Path) -> list[tuple[str, int, bytes]]:
    """(topic, log time, data) of every message, by the ordinary (seeking) reader; it
    needs the summary and the footer."""
    with path.open("rb") as f:
        reader = make_reader(f)
        assert reader.get_summary() is not None
        return [(c.topic, m.log_time, m.data) for _, c, m in reader.iter_messages()]


def _stream_until(path: Path, count: int) -> list:
    """The messages a copy of the file holds now, once it holds ``count`` (the writer is
    its own thread); fails if it never does."""
    deadline = time.monotonic() + 30
    while True:
        _, messages = read_log(path) if path.exists() else ({}, [])
        if len(messages) >= count or time.monotonic() > deadline:
            return messages
        time.sleep(0.05)


def _written(folder: Path, batches: int = 3, per_batch: int = 40) -> Path:
    """A complete log of a few station-sized batches, each ended by a boundary."""
    folder.mkdir(parents=True, exist_ok=True)
    log = SessionLog(folder / "session.mcap", META)
    for b in range(batches):
        for i in range(per_batch):
            n = b * per_batch + i
            log.put(
                (
                    "/a" if n % 3 else "/b",
                    "cyborg.event",
                    n,
                    b'{"n": %d, "pad": "%s"}' % (n, b"x" * 900),
                )
            )
        log.end_chunk()
    log.close()
    return log.path


def test_queued_messages_reach_the_disk_in_whole_chunks_without_more_coming(
    tmp_path: Path,
) -> None:
    """A quiet rig (nothing more queued) still closes its chunk: a kill now loses nothing."""
    log = SessionLog(tmp_path / "session.mcap", META)
    try:
        for i in range(5):
            log.put(("/a", "cyborg.event", i, b'{"i": %d}' % i))
        assert [m.log_time for m in _stream_until(log.path, 5)] == list(range(5))
        log.put(("/a", "cyborg.event", 5, b'{"i": 5}'))
        log.end_chunk()  # a station boundary
        assert len(_stream_until(log.path, 6)) == 6
    finally:
        log.close()


def test_a_log_cut_anywhere_keeps_every_whole_chunk(tmp_path: Path) -> None:
    complete = _written(tmp_path)
    data = complete.read_bytes()
    every = _ordinary(complete)
    with complete.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and len(summary.chunk_indexes) >= 3
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    cuts = [c.chunk_start_offset + c.chunk_length // 2 for c in chunks]  # inside a chunk
    cuts += [c.chunk_start_offset for c in chunks]  # just before one
    cuts += [len(data) - 40, 5]  # in the footer; in the magic
    for cut in cuts:
        archive = tmp_path / f"cut{cut}"
        folder = archive / "session"
        folder.mkdir(parents=True)
        path = folder / "session.mcap"
        path.write_bytes(data[:cut])
        whole = {
            (c.message_start_time, c.message_end_time)
            for c in chunks
            if c.chunk_start_offset + c.chunk_length <= cut
        }
        expected = [m for m in every if any(lo <= m[1] <= hi for lo, hi in whole)]
        if cut > chunks[-1].chunk_start_offset + chunks[-1].chunk_length:
            expected = every  # only the summary was cut
        assert recover_logs(archive) == [path]
        assert _ordinary(path) == expected, cut
        assert not (folder / DAMAGED).exists()  # only the unfinished record was lost
        metadata, messages = read_log(path)
        assert [(m.topic, m.log_time, m.data) for m in messages] == expected
        if cut > 8:
            assert metadata["session"] == META
        assert metadata["recovered"]["messages"] == str(len(expected))


def test_a_finished_log_is_left_alone(tmp_path: Path) -> None:
    complete = _written(tmp_path / "session")
    before = complete.read_bytes()
    assert recover_logs(tmp_path) == []
    assert complete.read_bytes() == before


def test_a_log_damaged_before_its_cut_keeps_what_precedes_and_the_original(
    tmp_path: Path,
) -> None:
    """A chunk whose bytes are wrong (its CRC fails) ends what can be trusted; the original
    is kept, hidden, for whoever wants to try harder."""
    complete = _written(tmp_path)
    with complete.open("rb") as f:
        chunks = sorted(
            make_reader(f).get_summary().chunk_indexes, key=lambda c: c.chunk_start_offset
        )
    data = bytearray(complete.read_bytes()[: chunks[-1].chunk_start_offset + 10])
    second = chunks[1]
    data[second.chunk_start_offset + second.chunk_length - 20] ^= 0xFF  # in its last message
    complete.write_bytes(bytes(data))
    messages, lost = recover(complete)
    first = _ordinary(complete)
    assert lost and (tmp_path / DAMAGED).read_bytes() == bytes(data)
    assert messages == len(first) > 0
    assert all(chunks[0].message_start_time <= m[1] <= chunks[0].message_end_time for m in first)


@pytest.mark.parametrize("size", [0, 3])
def test_a_log_cut_before_its_header_becomes_an_empty_log(tmp_path: Path, size: int) -> None:
    path = tmp_path / "s" / "session.mcap"
    path.parent.mkdir()
    path.write_bytes(b"\x89MCAP0\r\n"[:size])
    assert recover_logs(tmp_path) == [path]
    assert _ordinary(path) == []
