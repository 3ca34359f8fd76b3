"""Record, then replay through the ``chapter10`` backend: the same records come back, up to
the 100 ns / 0.1 µs quantization and the documented lossy error mapping."""

from __future__ import annotations

from collections import Counter
from datetime import datetime, timedelta
from pathlib import Path

import pytest

from drivers.backends.loopback import Injection, LoopbackMonitor
from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord
from drivers.monitor import open_monitor

START = datetime(2026, 5, 17, 8, 30, 0, 120000)
SAMPLE = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "chapter10" / \
    "sample.c10"

WORD_LEVEL = frozenset({"manchester", "parity", "bit_count_low", "bit_count_high",
                        "word_error"})
"""Word-level error names: one invalid-word flag per message in Chapter 10."""
FORMAT_FAMILY = frozenset({"illegal_format", "non_contiguous_data", "superseded",
                           "orphan_words", "babbling", "reserved_mode_code"})
"""Names that set the format-error flag, read back as ``illegal_format``."""
NOT_WRITTEN = frozenset({"intermessage_gap_short", "both_buses_active",
                         "time_tags_unavailable"})
"""Names about the traffic around a message or the monitor: not in a Chapter 10 message."""
TIME_QUANTUM_NS = 50
"""Half a 100 ns count: time tags are rounded to the nearest count."""
GAP_QUANTUM_NS = 50
"""Half a 0.1 µs gap unit."""
END_TOLERANCE_NS = 1_000
"""``end_ns`` is not stored; the reader rebuilds it from the words and gaps."""


def errors_after_round_trip(errors: tuple[str, ...]) -> set[str]:
    """The error names a record carrying ``errors`` reads back with (docs/recording.md):
    word-level names become ``word_error``, the format family ``illegal_format`` (a
    reserved mode code is found again from the command as well), names about the traffic
    around the message are dropped, the rest come back as they were."""
    out: set[str] = set()
    for name in errors:
        if name in NOT_WRITTEN:
            continue
        if name in WORD_LEVEL:
            out.add("word_error")
        elif name in FORMAT_FAMILY:
            out.add("illegal_format")
            if name == "reserved_mode_code":
                out.add(name)
        else:
            out.add(name)
    return out


def round_trip_differences(original: MonitorRecord, replayed: MonitorRecord, *,
                           channel: int, start: datetime | None = None) -> list[str]:
    """Every field of :class:`MonitorRecord` compared; the differences found, as text.

    Exact: ``bus``, ``format``, ``command``, ``command2``, ``data``, ``status``.
    Quantized: ``t_ns`` (±50 ns), each of ``gaps_ns`` (same count, ±50 ns).
    Mapped: ``errors`` (:func:`errors_after_round_trip`); ``word_errors`` come back empty.
    Rebuilt: ``end_ns`` (±1 µs). ``extra``: the ``channel`` id, and with ``start`` the
    absolute ``time`` (start + ``t_ns`` of the replayed record).
    """
    out = []
    for name in ("bus", "format", "command", "command2", "data", "status"):
        if getattr(original, name) != getattr(replayed, name):
            out.append(f"{name}: {getattr(original, name)!r} -> {getattr(replayed, name)!r}")
    if abs(original.t_ns - replayed.t_ns) > TIME_QUANTUM_NS:
        out.append(f"t_ns: {original.t_ns} -> {replayed.t_ns}")
    if len(original.gaps_ns) != len(replayed.gaps_ns) or any(
            abs(a - b) > GAP_QUANTUM_NS for a, b in zip(original.gaps_ns, replayed.gaps_ns,
                                                        strict=False)):
        out.append(f"gaps_ns: {original.gaps_ns} -> {replayed.gaps_ns}")
    if set(replayed.errors) != errors_after_round_trip(original.errors):
        out.append(f"errors: {original.errors} -> {replayed.errors}")
    if replayed.word_errors:
        out.append(f"word_errors: {replayed.word_errors} (Chapter 10 has none)")
    if abs(original.end_ns - replayed.end_ns) > END_TOLERANCE_NS:
        out.append(f"end_ns: {original.end_ns} -> {replayed.end_ns}")
    if replayed.extra.get("channel") != channel:
        out.append(f"extra channel: {replayed.extra.get('channel')} (written on {channel})")
    if start is not None:
        expected = (start + timedelta(microseconds=replayed.t_ns / 1000)).isoformat(
            timespec="microseconds")
        if replayed.extra.get("time") != expected:
            out.append(f"extra time: {replayed.extra.get('time')} (expected {expected})")
    return out


def _replay(path: Path, **options: object) -> list[MonitorRecord]:
    with open_monitor("chapter10", path=str(path), **options) as monitor:
        return list(monitor)


@pytest.fixture(scope="module")
def injected() -> list[MonitorRecord]:
    """Loopback traffic at bit level, all ten formats, with the errors a recording must
    carry: no response (a transmit command, a receive command, each terminal of an RT-RT
    transfer), word count low and high, Manchester and parity errors, a wrong sync, a late
    and an early response, a status word from the wrong RT, reserved status bits."""
    injections = [
        Injection("no_response", rt=5, sa=10),
        Injection("no_response", rt=5, sa=1, skip=1),
        Injection("no_response", format="RT_RT", responder=0),
        Injection("no_response", format="RT_RT", responder=1, skip=1),
        Injection("word_count_low", rt=5, sa=1, skip=3),
        Injection("word_count_high", rt=5, sa=2, skip=3),
        Injection("word_count_low", rt=5, sa=2, source="rt", skip=6),
        Injection("manchester", rt=5, sa=2),
        Injection("parity", rt=6, sa=1, word=3),
        Injection("sync", rt=5, sa=10, skip=7, word=3),
        Injection("late_response", rt=5, sa=10, skip=11),
        Injection("early_response", rt=5, sa=2, skip=8),
        Injection("wrong_rt_address", rt=5, sa=10, skip=5),
        Injection("reserved_status_bits", rt=5, sa=10, skip=9),
    ]
    with LoopbackMonitor(frames=250, injections=injections) as monitor:
        return list(monitor)


def test_loopback_traffic_with_errors_replays_to_the_same_records(
        tmp_path: Path, injected: list[MonitorRecord]) -> None:
    errors = Counter(name for record in injected for name in record.errors)
    for name in ("no_response", "word_count_low", "word_count_high", "manchester", "parity",
                 "sync", "late_response", "early_response", "wrong_rt_address",
                 "reserved_status_bits"):
        assert errors[name], f"the traffic should carry {name}"
    assert any(r.bus == "B" for r in injected)
    assert any(str(r.format) == "RT_RT" and "no_response" in r.errors for r in injected)
    path = tmp_path / "injected.c10"
    with Chapter10Writer(path, channel_id=6, start_time=START) as writer:
        writer.write(injected)
    replayed = _replay(path)
    assert len(replayed) == len(injected)
    problems = [f"record {i} ({original.format}, t {original.t_ns}): {difference}"
                for i, (original, back) in enumerate(zip(injected, replayed, strict=True))
                for difference in round_trip_differences(original, back, channel=6,
                                                         start=START)]
    assert not problems, "\n".join(problems[:20])


def test_times_off_the_100_ns_grid_come_back_rounded(tmp_path: Path) -> None:
    originals = [MonitorRecord(t_ns=t, bus="A", format=r.format, command=r.command,
                               status=r.status, gaps_ns=(6_049,))
                 for t, r in zip((1_049, 2_050, 3_999_951), [_mode_record()] * 3,
                                 strict=True)]
    path = tmp_path / "grid.c10"
    with Chapter10Writer(path, start_time=START) as writer:
        writer.write(originals)
    assert [r.t_ns for r in _replay(path)] == [1_000, 2_100, 4_000_000]
    assert [r.gaps_ns for r in _replay(path)] == [(6_000,)] * 3


def _mode_record() -> MonitorRecord:
    from drivers.mil1553.record import TransferFormat
    return MonitorRecord(t_ns=0, bus="A", format=TransferFormat.MODE, command=0x2C02,
                         status=(0x2800,))


def test_the_sample_recording_survives_being_recorded_again(tmp_path: Path) -> None:
    """Each 1553 channel of a real recorder's file, replayed and recorded again, replays to
    identical records (its times and gaps are already on the grid; its errors already in
    the Chapter 10 vocabulary)."""
    if not SAMPLE.exists():
        pytest.skip(f"sample recording not found at {SAMPLE}")
    first = _replay(SAMPLE)
    channels = sorted({r.extra["channel"] for r in first})
    totals: Counter[str] = Counter()
    for channel in channels:
        records = [r for r in first if r.extra["channel"] == channel]
        origin = min(r.t_ns for r in records)
        shifted = [_shifted(r, -origin) for r in records]
        path = tmp_path / f"channel{channel}.c10"
        with Chapter10Writer(path, channel_id=channel, start_time=START) as writer:
            writer.write(shifted)
        again = _replay(path)
        assert again == shifted, f"channel {channel}"
        assert [r.extra["channel"] for r in again] == [channel] * len(again)
        totals["messages"] += len(again)
        totals["rt_rt"] += sum(str(r.format) == "RT_RT" for r in again)
        totals["no_response"] += sum("no_response" in r.errors for r in again)
        totals["bus_b"] += sum(r.bus == "B" for r in again)
    assert totals == Counter(messages=475, rt_rt=11, no_response=27, bus_b=169)


def _shifted(record: MonitorRecord, by_ns: int) -> MonitorRecord:
    from dataclasses import replace
    return replace(record, t_ns=record.t_ns + by_ns, end_ns=record.end_ns + by_ns, extra={})
