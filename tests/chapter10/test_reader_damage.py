"""Damaged files: each bad packet is reported with its offset and skipped; the rest is read."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from drivers.chapter10.reader import Chapter10Reader
from drivers.chapter10.walker import looks_like_chapter10
from drivers.errors import CaptureFormatError


def three_packets(c10: Any) -> list[bytes]:
    """Three 1553 packets of one message each (RT 5, SA 1..3, one data word)."""
    packets = []
    for i in range(3):
        words = (5 << 11 | 1 << 10 | (i + 1) << 5 | 1, 5 << 11, 0x100 + i)
        packets.append(c10.ms1553([c10.Message(words, ipts=1_000_000 + i * 10_000)]))
    return packets


def read(path: Path) -> tuple[list[int], list[str]]:
    reader = Chapter10Reader(path)
    data = [r.data[0] for b in reader for r in b.records]
    return data, [str(i) for i in reader.issues]


def test_an_intact_file_reads_without_issues(c10: Any, tmp_path: Path) -> None:
    path = tmp_path / "ok.c10"
    path.write_bytes(b"".join(three_packets(c10)))
    assert read(path) == ([0x100, 0x101, 0x102], [])
    assert looks_like_chapter10(path)


def test_a_bad_sync_pattern_is_skipped_and_reported(c10: Any, tmp_path: Path) -> None:
    a, b, c = three_packets(c10)
    path = tmp_path / "sync.c10"
    path.write_bytes(a + b"\x00\x00" + b[2:] + c)
    data, issues = read(path)
    assert data == [0x100, 0x102]
    assert issues == [f"offset {len(a)}: bad sync pattern 0x0000 (expected 0xEB25)"]


def test_a_header_checksum_mismatch_is_skipped_and_reported(c10: Any, tmp_path: Path) -> None:
    a, b, c = three_packets(c10)
    damaged = bytearray(b)
    damaged[16] ^= 0x01  # one bit of the relative time counter
    path = tmp_path / "header.c10"
    path.write_bytes(a + bytes(damaged) + c)
    data, issues = read(path)
    assert data == [0x100, 0x102]
    assert issues == [f"offset {len(a)}: header checksum mismatch"]


def test_a_data_checksum_mismatch_is_skipped_and_reported(c10: Any, tmp_path: Path) -> None:
    a, b, c = three_packets(c10)
    damaged = bytearray(b)
    damaged[-6] ^= 0x40  # a data word
    path = tmp_path / "data.c10"
    path.write_bytes(a + bytes(damaged) + c)
    data, issues = read(path)
    assert data == [0x100, 0x102]
    assert issues == [f"offset {len(a)}: data checksum mismatch (type 0x19, channel 1); "
                      "packet skipped"]


def test_a_packet_cut_short_mid_file_loses_only_itself(c10: Any, tmp_path: Path) -> None:
    a, b, c = three_packets(c10)
    path = tmp_path / "cut.c10"
    path.write_bytes(a + b[:30] + c)
    data, issues = read(path)
    assert data == [0x100, 0x102]
    assert issues == [f"offset {len(a)}: packet (type 0x19, channel 1) cut short by the "
                      f"packet header at offset {len(a) + 30} (30 of {len(b)} bytes): the 0 "
                      "whole 1553 messages before the cut read, 1 of the 1 it announces lost"]


def test_a_truncated_last_packet_is_reported(c10: Any, tmp_path: Path) -> None:
    a, b, c = three_packets(c10)
    path = tmp_path / "end.c10"
    path.write_bytes(a + b + c[:-8])
    data, issues = read(path)
    assert data == [0x100, 0x101]
    assert issues == [f"offset {len(a) + len(b)}: packet (type 0x19, channel 1) cut short "
                      f"at the end of the file ({len(c) - 8} of {len(c)} bytes): the 0 whole "
                      "1553 messages before the cut read, 1 of the 1 it announces lost"]
    path.write_bytes(a + b + c[:10])
    assert read(path)[1] == [f"offset {len(a) + len(b)}: truncated packet header (10 bytes at "
                             "the end of the file)"]


def test_garbage_between_packets_is_passed_over(c10: Any, tmp_path: Path) -> None:
    a, b, c = three_packets(c10)
    path = tmp_path / "garbage.c10"
    path.write_bytes(a + b"\x25\xeb" + bytes(range(200)) + b + c)
    data, issues = read(path)
    assert data == [0x100, 0x101, 0x102]
    assert len(issues) == 1 and issues[0].startswith(f"offset {len(a)}: ")


def test_a_message_longer_than_its_packet_is_reported(c10: Any, tmp_path: Path) -> None:
    from chapter10.ms1553 import MS1553F1
    # A message header claiming 40 bytes where 4 follow, inside a valid packet.
    packet = MS1553F1(data_type=0x19, channel_id=1, header_version=3, rtc=5, count=1)
    packet.append(MS1553F1.Message(data=b"\x21\x2c\x00\x28", ipts=5, length=40))
    raw = bytearray(bytes(packet))
    path = tmp_path / "message.c10"
    path.write_bytes(bytes(raw) + three_packets(c10)[0])
    reader = Chapter10Reader(path)
    records = [r for b in reader for r in b.records]
    assert [r.data for r in records] == [(0x100,)]
    assert [str(i) for i in reader.issues] == ["offset 0: 1553 message 1 cut short (4 of 40 "
                                               "bytes); rest of the packet skipped"]


def test_a_file_that_is_not_chapter10_is_one_clear_error(tmp_path: Path) -> None:
    path = tmp_path / "noise.bin"
    path.write_bytes(bytes(range(256)) * 10)
    assert not looks_like_chapter10(path)
    with pytest.raises(CaptureFormatError, match=r"noise\.bin: not a Chapter 10 file"):
        list(Chapter10Reader(path))
    with pytest.raises(CaptureFormatError, match="cannot open"):
        Chapter10Reader(tmp_path / "missing.c10")


def test_a_packet_holding_fewer_messages_than_it_announces_is_reported(c10: Any,
                                                                       tmp_path: Path) -> None:
    from chapter10.ms1553 import MS1553F1
    packet = MS1553F1(data_type=0x19, channel_id=1, header_version=3, rtc=5, count=3)
    packet.append(MS1553F1.Message(data=bytes.fromhex("212801000028"), ipts=5,
                                   length=6, gap_time=70))
    path = tmp_path / "count.c10"
    path.write_bytes(bytes(packet))
    reader = Chapter10Reader(path)
    records = [r for b in reader for r in b.records]
    assert [(r.rt, r.data, r.status) for r in records] == [(5, (1,), (0x2800,))]
    assert [str(i) for i in reader.issues] == ["offset 0: 1553 packet announces 3 messages "
                                               "but holds 1"]


@pytest.mark.parametrize("seed", range(8))
def test_random_damage_to_the_sample_never_stops_the_reader(sample_c10: Path, tmp_path: Path,
                                                            seed: int) -> None:
    import numpy as np
    rng = np.random.default_rng(seed)
    blob = bytearray(sample_c10.read_bytes())
    for at in rng.integers(0, len(blob), size=6):
        blob[at] ^= int(rng.integers(1, 256))
    cut = int(rng.integers(len(blob) // 2, len(blob)))
    path = tmp_path / "damaged.c10"
    path.write_bytes(bytes(blob[:cut]))
    reader = Chapter10Reader(path)
    records = [r for b in reader for r in b.records]
    assert len(records) <= 475
    assert reader.issues  # the cut at least is reported
    assert all(r.command is not None for r in records)


def arinc(c10: Any, n: int = 40) -> bytes:
    """An ARINC 429 packet: a type the 1553 reader (``arinc429=False``) passes over."""
    return c10.arinc429(list(range(1, n + 1)), rtc=1_000_000, gaps=[10] * n)


def read_1553(path: Path) -> tuple[list[int], list[str], set[int]]:
    reader = Chapter10Reader(path, arinc429=False)
    data = [r.data[0] for b in reader for r in b.records]
    return data, [str(i) for i in reader.issues], set(reader.walker.types_seen)


def test_a_packet_passed_over_and_cut_short_still_gives_what_follows(c10: Any,
                                                                      tmp_path: Path) -> None:
    """A packet of a type not read is passed over by its length, unread; cut short (the next
    packet's header inside it), it is read and reported after all, and the packet whose
    header follows the cut is read."""
    a, b, c = three_packets(c10)
    other = arinc(c10)
    path = tmp_path / "cut-other.c10"
    path.write_bytes(a + other[:60] + b + c + other * 3)   # its length ends inside the file
    data, issues, _ = read_1553(path)
    assert data == [0x100, 0x101, 0x102]
    assert issues == [f"offset {len(a)}: data checksum mismatch (type 0x38, channel 9); "
                      "packet skipped"]


def test_packets_passed_over_leave_the_rest_and_the_issues_as_they_were(c10: Any,
                                                                         tmp_path: Path) -> None:
    a, b, c = three_packets(c10)
    other = arinc(c10)
    path = tmp_path / "other.c10"
    path.write_bytes(other + a + other + other + b + c + other)
    assert read_1553(path) == ([0x100, 0x101, 0x102], [], {0x19, 0x38})
    path.write_bytes(a + other + b + c + other[:-9])   # the last one cut at the end
    data, issues, _ = read_1553(path)
    assert data == [0x100, 0x101, 0x102]
    assert len(issues) == 1 and "truncated packet (type 0x38" in issues[0]
    path.write_bytes(a + other + b"\x00" * 7 + b + c)   # garbage after a passed-over packet
    data, issues, _ = read_1553(path)
    assert data == [0x100, 0x101, 0x102]
    assert issues == [f"offset {len(a) + len(other)}: bad sync pattern 0x0000 (expected "
                      "0xEB25)"]
