"""Record times: the stamped bit moved to the first sync edge, absolute time, counter wrap."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path
from typing import Any

import pytest

from drivers.chapter10.reader import Chapter10Reader
from drivers.chapter10.timebase import Timebase
from drivers.mil1553.record import MonitorRecord

RT_BC = (5 << 11 | 1 << 10 | 1 << 5 | 2, 5 << 11, 0xAAAA, 0x5555)  # cmd, status, 2 data


def replay(path: Path, *packets: bytes, **options: Any) -> list[MonitorRecord]:
    path.write_bytes(b"".join(packets))
    return [r for b in Chapter10Reader(path, **options) for r in b.records]


@pytest.mark.parametrize(("tag_bits", "stamp_offset_ns"), [
    (1, 0),                          # first bit of the first word: the start itself
    (2, 20_000),                     # last bit of the command word
    (0, 4 * 20_000 + 8_000 - 2_000),  # last bit of the last word: 4 words + idle of the gap
])
def test_the_stamped_bit_is_moved_to_the_first_sync_edge(c10: Any, tmp_path: Path,
                                                         tag_bits: int,
                                                         stamp_offset_ns: int) -> None:
    origin = 10_000_000
    stamp = origin + 50_000  # 5 ms after the first packet, in 100 ns counts
    message = c10.Message(RT_BC, ipts=stamp, gap1=80)
    (record,) = replay(tmp_path / "t.c10", c10.ms1553([message], rtc=origin,
                                                       time_tag_bits=tag_bits))
    assert record.t_ns == 5_000_000 - stamp_offset_ns
    assert record.end_ns - record.t_ns == 4 * 20_000 + 8_000 - 2_000
    assert record.gaps_ns == (8_000,)


def test_absolute_time_from_a_time_packet(c10: Any, tmp_path: Path) -> None:
    when = datetime(2024, 3, 5, 12, 0, 1, 250_000)
    records = replay(tmp_path / "abs.c10", c10.time(1_000, when),
                     c10.ms1553([c10.Message(RT_BC, ipts=1_000 + 12_345)]))
    assert records[0].t_ns == 12_345 * 100
    assert records[0].extra["time"] == "2024-03-05T12:00:01.251234"


def test_day_of_year_time_needs_the_year(c10: Any, tmp_path: Path) -> None:
    packets = (c10.time(0, datetime(2023, 2, 1, 8, 30), day_format=True),
               c10.ms1553([c10.Message(RT_BC, ipts=10_000_000)]))
    without = replay(tmp_path / "doy.c10", *packets)
    assert without[0].extra["time"] == "day 032 08:30:01.000000"
    with_year = replay(tmp_path / "doy.c10", *packets, year=2023)
    assert with_year[0].extra["time"] == "2023-02-01T08:30:01.000000"


def test_no_time_packet_no_absolute_time(c10: Any, tmp_path: Path) -> None:
    (record,) = replay(tmp_path / "rel.c10", c10.ms1553([c10.Message(RT_BC, ipts=77)]))
    assert record.t_ns == 0 and "time" not in record.extra


def test_the_48_bit_counter_wraps() -> None:
    base = Timebase()
    base.start((1 << 48) - 10)
    assert base.ns(5) == 15 * 100
    assert base.ns((1 << 48) - 12) == -200


def test_secondary_header_message_stamps_fall_back_to_the_packet_time(c10: Any,
                                                                       tmp_path: Path) -> None:
    from chapter10.ms1553 import MS1553F1
    packet = MS1553F1(data_type=0x19, channel_id=1, header_version=3, rtc=5_000, count=1,
                      ipts_source=1)
    packet.append(MS1553F1.Message(data=bytes(2 * len(RT_BC)), ipts=123_456_789, length=8))
    path = tmp_path / "ipts.c10"
    path.write_bytes(c10.ms1553([c10.Message(RT_BC, ipts=1_000)], rtc=1_000) + bytes(packet))
    reader = Chapter10Reader(path)
    records = [r for b in reader for r in b.records]
    # the packet's counter, not the message's stamp (time-tag bits 0: the last bit, so the
    # four words' 80 µs come off)
    assert [r.t_ns for r in records] == [0, 4_000 * 100 - 4 * 20_000]
    (issue,) = reader.issues
    assert "secondary-header format are not supported; the packet's time is used" in str(issue)
