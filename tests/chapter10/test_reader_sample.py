"""The real sample recording replays completely, each record true to the packet it came from.

The packets are parsed again here with ``struct`` alone (not pychapter10, not the reader), and
the records are checked against those raw words, block status words, gaps and time stamps.
"""

from __future__ import annotations

import struct
from collections import Counter
from pathlib import Path

import pytest

from drivers.chapter10.reader import Chapter10Reader
from drivers.mil1553.record import MonitorRecord, TransferFormat

STATUS_FIRST = {TransferFormat.RT_BC, TransferFormat.MODE_TX_DATA, TransferFormat.RT_RT}


def raw_messages(path: Path) -> list[dict[str, int | tuple[int, ...]]]:
    """Every 1553 message of the file, straight from the bytes (full packets only)."""
    blob = path.read_bytes()
    out: list[dict[str, int | tuple[int, ...]]] = []
    pos = 0
    first_rtc = None
    while pos + 24 <= len(blob):
        sync, channel, plen, _dlen, _, _, flags, dtype = struct.unpack_from("<HHIIBBBB", blob, pos)
        assert sync == 0xEB25
        rtc = int.from_bytes(blob[pos + 16:pos + 22], "little")
        first_rtc = rtc if first_rtc is None else first_rtc
        if pos + plen > len(blob):
            break
        if dtype == 0x19:
            body = pos + 24 + (12 if flags & 0x80 else 0)
            csdw = struct.unpack_from("<I", blob, body)[0]
            at = body + 4
            for _ in range(csdw & 0xFFFFFF):
                ipts, bsw, gaps, length = struct.unpack_from("<QHHH", blob, at)
                words = struct.unpack_from(f"<{length // 2}H", blob, at + 14)
                out.append({"channel": channel, "ipts": ipts & (1 << 48) - 1,
                            "first_rtc": first_rtc, "tag_bits": csdw >> 30,
                            "bsw": bsw, "gaps": gaps, "words": words})
                at += 14 + length + (length & 1)
        pos += plen
    return out


@pytest.fixture(scope="module")
def replayed(sample_c10: Path) -> tuple[list[MonitorRecord], Chapter10Reader]:
    reader = Chapter10Reader(sample_c10)
    records = [r for batch in reader for r in batch.records]
    reader.close()
    return records, reader


def test_the_sample_replays_completely(replayed: tuple[list[MonitorRecord], Chapter10Reader]
                                       ) -> None:
    records, reader = replayed
    assert len(records) == 475
    assert sum(r.format is TransferFormat.RT_RT for r in records) == 11
    assert sum("no_response" in r.errors for r in records) == 27
    assert sum(r.bus == "B" for r in records) == 169
    # nothing else is wrong in the sample; the file ends inside a video packet, said once
    assert Counter(e for r in records for e in r.errors) == {"no_response": 27}
    assert [str(i) for i in reader.issues] == [
        "offset 1042864: truncated packet (type 0x40, 5712 of 15636 bytes at the end of the "
        "file)"]
    assert reader.channels_seen == {2, 3, 4, 5}


def bus_order(record: MonitorRecord) -> list[int]:
    assert record.command is not None
    words = [record.command] + ([record.command2] if record.command2 is not None else [])
    if record.format in STATUS_FIRST:
        return [*words, *record.status[:1], *record.data, *record.status[1:]]
    return [*words, *record.data, *record.status]


def test_every_record_holds_its_packets_words_in_their_roles(
        replayed: tuple[list[MonitorRecord], Chapter10Reader], sample_c10: Path) -> None:
    records, _ = replayed
    raw = raw_messages(sample_c10)
    assert len(raw) == len(records)
    for record, msg in zip(records, raw, strict=True):
        assert bus_order(record) == list(msg["words"])  # type: ignore[arg-type]
        assert record.extra["channel"] == msg["channel"]
        assert record.extra["block_status"] == msg["bsw"]


def test_every_records_word_counts_match_its_command(
        replayed: tuple[list[MonitorRecord], Chapter10Reader]) -> None:
    records, _ = replayed
    seen_receive_timeout = seen_transmit_timeout = False
    for r in records:
        timed_out = "no_response" in r.errors
        if r.format is TransferFormat.RT_RT:
            assert r.wc == (r.command2 or 0) & 31 or 32
            assert len(r.data) == r.wc and len(r.status) == 2
        elif r.is_mode:
            has_data = (r.mode_code or 0) >= 16
            assert len(r.data) == (1 if has_data and not timed_out else 0)
            assert len(r.status) == (0 if timed_out else 1)
        elif r.tr == "T":
            # a transmit command that timed out holds the command alone
            assert len(r.data) == (0 if timed_out else r.wc)
            assert len(r.status) == (0 if timed_out else 1)
            seen_transmit_timeout |= timed_out
        else:
            # a receive command holds its data words whether or not the terminal answered
            assert len(r.data) == r.wc
            assert len(r.status) == (0 if timed_out else 1)
            seen_receive_timeout |= timed_out
        assert len(r.gaps_ns) == len(r.status)
    assert seen_receive_timeout and seen_transmit_timeout


@pytest.mark.parametrize("index", [0, 1, 57, 100, 203, 311, 402, 474])
def test_sampled_records_field_by_field(replayed: tuple[list[MonitorRecord], Chapter10Reader],
                                        sample_c10: Path, index: int) -> None:
    records, _ = replayed
    msg = raw_messages(sample_c10)[index]
    r = records[index]
    words: tuple[int, ...] = msg["words"]  # type: ignore[assignment]
    bsw: int = msg["bsw"]  # type: ignore[assignment]
    gaps: int = msg["gaps"]  # type: ignore[assignment]
    assert msg["tag_bits"] == 1  # the sample stamps the first bit of the first word
    assert r.t_ns == ((msg["ipts"] - msg["first_rtc"]) * 100)  # type: ignore[operator]
    assert r.bus == ("B" if bsw & 1 << 13 else "A")
    assert (r.format is TransferFormat.RT_RT) == bool(bsw & 1 << 11)
    assert r.command == words[0]
    assert r.rt == words[0] >> 11 and r.sa == words[0] >> 5 & 31
    expected_gaps = [(gaps & 0xFF) * 100, (gaps >> 8) * 100][:len(r.status)]
    assert list(r.gaps_ns) == expected_gaps
    idle = sum(g - 2000 for g in expected_gaps)
    assert r.end_ns - r.t_ns == len(words) * 20_000 + idle
    assert ("no_response" in r.errors) == bool(bsw & 1 << 9)
    assert r.extra["time"].startswith("day 343 16:47:")


def test_channels_select_what_is_read(sample_c10: Path) -> None:
    reader = Chapter10Reader(sample_c10, channels=[2], arinc429=False)
    batches = list(reader)
    assert {b.channel for b in batches} == {2}
    assert all(b.arinc429 is None for b in batches)
    assert sum(len(b.records) for b in batches) == sum(
        1 for m in raw_messages(sample_c10) if m["channel"] == 2)


def test_a_known_year_gives_a_full_date(sample_c10: Path) -> None:
    reader = Chapter10Reader(sample_c10, year=2019, arinc429=False)
    first = next(iter(reader)).records[0]
    assert first.extra["time"].startswith("2019-12-09T16:47:12.")
