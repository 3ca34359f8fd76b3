"""One record the writer cannot store never stops a recording: it is counted and skipped,
and the records after it (in the same batch too) are written."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

from drivers.chapter10.reader import Chapter10Reader
from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.cli.commands.record import summary_line
from mapr_daemon.service.recorder import SessionRecorder

WILD_NS = 10**20
"""A time tag some 3,000 years after the start: its time packet's year would pass 3999."""


def record(t_ns: int, value: int) -> MonitorRecord:
    return MonitorRecord(t_ns, "A", TransferFormat.BC_RT, 5 << 11 | 1 << 5 | 1, data=(value,),
                         status=(5 << 11,), gaps_ns=(6_000,))


def values(path: Path) -> list[int]:
    reader = Chapter10Reader(path)
    try:
        return [r.data[0] for batch in reader for r in batch.records]
    finally:
        reader.close()


def test_a_time_tag_the_file_cannot_hold_is_skipped_and_counted(tmp_path: Path) -> None:
    path = tmp_path / "flight.c10"
    with Chapter10Writer(path, start_time=datetime(2025, 1, 1)) as writer:
        writer.write([record(0, 1), record(WILD_NS, 2), record(1_000_000, 3)])
        writer.write([record(2_000_000, 4)])
    assert values(path) == [1, 3, 4]
    stats = writer.stats
    assert (stats.messages, stats.skipped) == (3, 1)
    assert summary_line(stats, "f.c10").endswith(
        "to f.c10; 1 with a time tag the file cannot hold, skipped")


def test_the_daemon_keeps_recording_past_such_a_record(tmp_path: Path) -> None:
    recorder = SessionRecorder(str(tmp_path), 1)
    recorder.write([record(0, 1), record(WILD_NS, 2)])
    recorder.write([record(3_000_000, 3)])
    recorder.close()
    assert not recorder.failed
    assert [v for f in recorder.files for v in values(f)] == [1, 3]
