"""The batch reader (numpy over packet bytes) gives exactly the records and the problems the
per-message reader (pychapter10's parse, one record at a time) gives: on the real sample
recording, on varied traffic the project's writer makes, and on damaged copies of both."""

from __future__ import annotations

import random
from datetime import datetime
from pathlib import Path

import pytest

from drivers.chapter10.reader import Chapter10Reader
from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MESSAGE_ERROR_NAMES, MonitorRecord, TransferFormat

from .conftest import SAMPLE

SEED = 20261124


def varied_records(count: int, seed: int) -> list[MonitorRecord]:
    """Every transfer format, odd commands (broadcast, reserved mode codes), missing and
    extra words, time-outs and error names, both buses: what a recorder may store."""
    rng = random.Random(seed)
    records: list[MonitorRecord] = []
    t = 0
    for _ in range(count):
        fmt = rng.choice(list(TransferFormat)[:-1])
        command = rng.getrandbits(16)
        command2 = rng.getrandbits(16) if fmt in (TransferFormat.RT_RT,
                                                  TransferFormat.BCAST_RT_RT) else None
        data = tuple(rng.getrandbits(16) for _ in range(rng.choice((0, 1, 2, 5, 32, 33))))
        status = tuple(rng.getrandbits(16) for _ in range(rng.choice((0, 1, 1, 2))))
        gaps = tuple(rng.choice((0, 3_000, 6_000, 8_100, 13_000)) for _ in status)
        errors = tuple(sorted(set(rng.sample(MESSAGE_ERROR_NAMES, rng.choice((0, 0, 1, 2))))))
        span = (1 + len(data) + len(status)) * 20_000 + sum(gaps)
        records.append(MonitorRecord(t, rng.choice("AB"), fmt, command, data=data,
                                     status=status, gaps_ns=gaps, errors=errors,
                                     command2=command2, end_ns=t + span))
        t += span + rng.choice((4_000, 10_000, 2_000_000))
    return records


Read = list[tuple[int, MonitorRecord, dict[str, object]]]


def _read(path: Path, **options: object) -> tuple[Read, list[str]]:
    reader = Chapter10Reader(path, **options)  # type: ignore[arg-type]
    out = [(b.offset, r, r.extra) for b in reader for r in b.records]
    return out, [str(i) for i in reader.issues]


def _assert_same(path: Path) -> int:
    """Both ways agree, except that the batch reader also keeps the whole messages of a 1553
    packet cut short (the per-message path, pychapter10's parse, skips such a packet): those
    messages and the issue naming the cut are set aside before comparing."""
    reference, issues = _read(path, batched=False)
    batched, batch_issues = _read(path)
    cut = {int(i.split(":")[0].split()[1]) for i in batch_issues if "cut short" in i
           and "whole 1553 messages" in i}
    batched = [item for item in batched if item[0] not in cut]
    assert batched == reference
    assert [i for i in batch_issues if int(i.split(":")[0].split()[1]) not in cut] == [
        i for i in issues if int(i.split(":")[0].split()[1]) not in cut]
    merged = Chapter10Reader(path)
    batches = list(merged.batches(max_messages=300))
    for batch in batches:
        if batch.ms1553 is not None:   # one message at a time, as the whole batch
            one = [batch.ms1553.record(i) for i in range(len(batch.ms1553))]
            assert [(r, r.extra) for r in one] == [(r, r.extra) for r in batch.records]
    records = [(r, r.extra) for b in batches for r in b.records
               if r.extra.get("offset", b.offset) not in cut]
    if not cut:
        assert records == [(r, e) for _, r, e in reference]
        assert [str(i) for i in merged.issues] == issues
    return len(reference)


def test_the_sample_recording_reads_the_same_both_ways() -> None:
    if not SAMPLE.is_file():
        pytest.skip(f"the sample Chapter 10 recording is not at {SAMPLE}")
    assert _assert_same(SAMPLE) > 400


@pytest.fixture(scope="module")
def varied(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("batch") / "varied.c10"
    with Chapter10Writer(path, start_time=datetime(2026, 3, 1, 8)) as writer:
        writer.write(varied_records(3000, SEED))
    return path


def test_varied_traffic_from_the_writer_reads_the_same_both_ways(varied: Path) -> None:
    assert _assert_same(varied) == 3000


@pytest.mark.parametrize("year", [None, 2024])
def test_day_of_year_time_and_a_year_read_the_same(year: int | None, tmp_path: Path) -> None:
    path = tmp_path / "day.c10"
    with Chapter10Writer(path, start_time=datetime(2024, 12, 31, 23, 59, 59)) as writer:
        writer.write(varied_records(400, SEED + 1))
    reference, _ = _read(path, batched=False, year=year)
    assert _read(path, year=year)[0] == reference


@pytest.mark.parametrize("damage", range(12))
def test_damaged_copies_read_the_same_both_ways(damage: int, varied: Path,
                                                tmp_path: Path) -> None:
    sources = [varied] + ([SAMPLE] if SAMPLE.is_file() else [])
    source = sources[damage % len(sources)]
    data = bytearray(source.read_bytes())
    rng = random.Random(SEED + damage)
    for _ in range(1 + damage % 4):
        at = rng.randrange(len(data))
        if damage % 3 == 0:
            data[at:at + 8] = bytes(8)
        else:
            data[at] ^= 1 << rng.randrange(8)
    if damage % 5 == 4:
        del data[rng.randrange(len(data) // 2, len(data)):]
    path = tmp_path / "damaged.c10"
    path.write_bytes(bytes(data))
    _assert_same(path)


def test_impossible_lengths_and_short_packets_read_the_same(c10: object,
                                                            tmp_path: Path) -> None:
    from chapter10.ms1553 import MS1553F1

    from .conftest import _Ms1553
    packet = _Ms1553(data_type=0x19, channel_id=3, header_version=3, data_checksum=0,
                     rtc=1000, time_tag_bits=0, count=5)
    for data in (b"\x20\x28\x01\x00\x00\x28", b"\x01\x02\x03", b"", b"\x22\x2c\x00\x2c"):
        packet.append(MS1553F1.Message(data=data, ipts=1200, gap_time=0x5040,
                                       length=len(data), bus=1, me=1, le=1))
    path = tmp_path / "odd.c10"
    path.write_bytes(bytes(packet))
    reference, issues = _read(path, batched=False)
    assert len(reference) == 2 and len(issues) == 2
    assert _read(path) == (reference, issues)
