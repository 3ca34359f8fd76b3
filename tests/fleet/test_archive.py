"""Telling each recording's tail and flight from the path, and the archive's bad files."""

from __future__ import annotations

from pathlib import Path

import pytest

from mapr_daemon.errors import ConfigError
from mapr_daemon.fleet.archive import compile_pattern, discover


def _touch(path: Path, content: bytes) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(content)
    return path


def test_default_pattern_reads_tail_folder_and_flight_number(tmp_path: Path) -> None:
    _touch(tmp_path / "N7" / "flight-0010.ch10", b"ten")
    _touch(tmp_path / "N7" / "flight-0002.ch10", b"two")
    _touch(tmp_path / "F-AB" / "2026" / "leg_3.c10", b"three")
    _touch(tmp_path / "notes.txt", b"not a recording")
    _touch(tmp_path / "backup" / "N7" / "flight-0002.ch10", b"two")   # same content: once
    found, bad = discover([tmp_path])
    assert [(r.tail, r.flight) for r in found] == [("2026", 3), ("N7", 2), ("N7", 10)]
    assert bad == []
    assert len({r.digest for r in found}) == 3


def test_custom_pattern_and_files_that_do_not_match(tmp_path: Path) -> None:
    good = _touch(tmp_path / "fleet" / "TAIL_N55_FLT_0042.ch10", b"a")
    odd = _touch(tmp_path / "fleet" / "unnamed.ch10", b"b")
    found, bad = discover([good, odd], r"TAIL_(?P<tail>\w+?)_FLT_(?P<flight>\d+)")
    assert [(r.tail, r.flight, r.path) for r in found] == [("N55", 42, str(good))]
    assert [b.path for b in bad] == [str(odd)]
    assert "tail and flight" in bad[0].reason


def test_manifest_declares_flight_hours(tmp_path: Path) -> None:
    _touch(tmp_path / "N1" / "flight-0001.ch10", b"x")
    (tmp_path / "fleet.json").write_text(
        '{"recordings": [{"path": "N1/flight-0001.ch10", "flight_hours": 2.25}]}')
    (recording,), _ = discover([tmp_path])
    assert recording.flight_hours == 2.25


def test_a_pattern_without_the_groups_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="flight"):
        compile_pattern(r"(?P<tail>\w+)/\d+")
    with pytest.raises(ConfigError, match="regular expression"):
        compile_pattern(r"(?P<tail>")


def test_later_flights_wait_for_the_earlier_ones_of_their_tail() -> None:
    from mapr_daemon.fleet.archive import Recording
    from mapr_daemon.fleet.runner import FlightOrder
    from mapr_daemon.fleet.task import TaskResult

    recordings = [Recording(f"{t}/{f}.ch10", t, f, f"{t}{f}") for t in ("A", "B")
                  for f in (3, 1, 2)]
    order = FlightOrder(recordings)

    def done(tail: str, flight: int) -> list[tuple[str, int]]:
        (recording,) = [r for r in recordings if (r.tail, r.flight) == (tail, flight)]
        out = order.ready(TaskResult(recording, "cfg", True))
        return [(r.recording.tail, r.recording.flight) for r in out]

    assert done("A", 3) == []
    assert done("B", 1) == [("B", 1)]   # another tail is not held back
    assert done("A", 2) == []
    assert done("A", 1) == [("A", 1), ("A", 2), ("A", 3)]
    assert done("B", 3) == []
    assert done("B", 2) == [("B", 2), ("B", 3)]


def test_tail_from_tmats_when_the_recorder_writes_it(tmp_path: Path) -> None:
    from drivers.chapter10.recording_packets import tmats_packet
    from drivers.chapter10.tmats import TMATS_VERSION

    text = "G\\PN:OTHER RECORDER;\r\nG\\TA:N900XY;\r\n"
    with_tail = _touch(tmp_path / "box7" / "rec-0004.ch10",
                       tmats_packet(0, text, TMATS_VERSION))
    without = _touch(tmp_path / "box7" / "rec-0005.ch10",
                     tmats_packet(0, "G\\PN:MAPR;\r\n", TMATS_VERSION))
    found, bad = discover([with_tail, without], tail_tmats="G\\TA")
    assert [(r.tail, r.flight) for r in found] == [("N900XY", 4), ("box7", 5)] and not bad


def test_a_recording_at_the_archive_root_is_reported_not_named_after_the_folder(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    archive = tmp_path / "N999"   # a folder that looks like a tail
    _touch(archive / "flight-0003.ch10", b"at the root")
    _touch(archive / "N7" / "flight-0001.ch10", b"one")
    monkeypatch.chdir(tmp_path)
    found, bad = discover(["N999"])   # relative: every path comes back absolute
    assert [(r.tail, r.flight, r.path) for r in found] == [
        ("N7", 1, str(archive / "N7" / "flight-0001.ch10"))]
    assert [b.path for b in bad] == [str(archive / "flight-0003.ch10")]
    assert "below the archive" in bad[0].reason


def test_a_file_given_by_name_is_named_by_its_folder_and_made_absolute(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _touch(tmp_path / "N7" / "flight-0004.ch10", b"four")
    monkeypatch.chdir(tmp_path)
    (recording,), bad = discover(["N7/flight-0004.ch10"])
    assert (recording.tail, recording.flight) == ("N7", 4) and bad == []
    assert recording.path == str(tmp_path / "N7" / "flight-0004.ch10")


def test_an_optional_tail_group_takes_the_tail_from_tmats_or_reports_the_file(
        tmp_path: Path) -> None:
    from drivers.chapter10.writer import Chapter10Writer

    with Chapter10Writer(tmp_path / "session-000002-x.ch10", tail="N42") as writer:
        writer.write([])
    with Chapter10Writer(tmp_path / "session-000003-x.ch10") as writer:   # no tail
        writer.write([])
    pattern = r"(?:^|/)(?:(?P<tail>[^/]+)/)?session-(?P<flight>\d+)-[^/]*\.ch10$"
    found, bad = discover([tmp_path], pattern, tail_tmats="G\\TA")
    assert [(r.tail, r.flight) for r in found] == [("N42", 2)]
    assert [Path(b.path).name for b in bad] == ["session-000003-x.ch10"]
    assert "no tail in its path nor in its TMATS G\\TA" in bad[0].reason
