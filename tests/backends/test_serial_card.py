"""The ``serial`` backend on real pty pairs: line protocol, garbage, unplug and replug,
clear open errors, the registry entry."""

from __future__ import annotations

import queue
import random
import threading

import pytest

from drivers.backends.open1553 import LineSplitter, LineWord, format_line, parse_line
from drivers.backends.open1553_framer import LineFramer, horizon
from drivers.backends.serial_card import SerialMonitor, explain
from drivers.errors import BackendError
from drivers.mil1553.assembler import MessageAssembler
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.wordbatch import SYNC_CMD, SYNC_DATA, empty_words
from drivers.monitor import backend_class

from .card_emulators import SerialCard


def _line(sync: int, value: int, gap: bool = True, parity: bool = True) -> bytes:
    return format_line(LineWord(sync, gap, parity, False, value))


def _bc_rt(rt: int = 5) -> bytes:
    """A BC-RT of two data words and its status, as the card sends it."""
    return (_line(SYNC_CMD, rt << 11 | 1 << 5 | 2) + _line(SYNC_DATA, 0x1234, gap=False) +
            _line(SYNC_DATA, 0xABCD, gap=False) + _line(SYNC_CMD, rt << 11))


def test_line_protocol_round_trip() -> None:
    word = LineWord(SYNC_CMD, True, True, False, 0x5555)
    assert format_line(word) == b"CMDS;D1;P1;I0;Hx5555\r"
    assert parse_line(b"CMDS;D1;P1;I0;Hx5555") == word
    assert parse_line(b"DATA;D0;P0;I1;Hxbeef") == LineWord(SYNC_DATA, False, False, True,
                                                             0xBEEF)
    for junk in (b"CMDS;D1;P1;I0;Hx555", b"XXXX;D1;P1;I0;Hx5555", b"\xff\xfe", b"CMDS;D2;P1;"):
        assert parse_line(junk) is None


def test_splitter_resynchronizes() -> None:
    splitter = LineSplitter()
    assert splitter.feed(b"CMDS;D1;P1;I0;Hx") == []
    assert splitter.feed(b"5555\r\rDATA") == [b"CMDS;D1;P1;I0;Hx5555"]
    assert splitter.feed(b"x" * 100) == [b"DATA" + b"x" * 100]  # cut: no terminator came
    assert splitter.feed(b"\nDATA;D0;P1;I0;Hx0001\r") == [b"DATA;D0;P1;I0;Hx0001"]


def _frame(lines: list[bytes], arrivals: list[int]) -> list[MonitorRecord]:
    """The records a framer and the assembler make of ``lines`` reaching the host at
    ``arrivals`` (host wall times, ns)."""
    framer = LineFramer()
    words = empty_words(len(lines))
    for i, (line, wall) in enumerate(zip(lines, arrivals, strict=True)):
        word = parse_line(line.rstrip(b"\r"))
        assert word is not None
        t = framer.place(word.sync, word.gap, word.value, wall)
        words[i] = (t, 0, word.sync, word.value, 0, t + 19_500)
    return MessageAssembler(time_tags=False).assemble(words)


def test_framing_does_not_depend_on_arrival_times() -> None:
    """The same lines framed with arrival times all equal, wildly irregular (a host stalling
    between reads) or seconds apart give the same messages: the card's report decides."""
    rt_bc = 7 << 11 | 1 << 10 | 1 << 5 | 2
    lines = [*_bc_rt(5).splitlines(keepends=True),
             _line(SYNC_CMD, rt_bc),  # unanswered: the next command comes instead
             _line(SYNC_CMD, 9 << 11 | 3 << 5 | 1), _line(SYNC_DATA, 0x0101, gap=False),
             _line(SYNC_CMD, 9 << 11),
             _line(SYNC_CMD, rt_bc), _line(SYNC_CMD, 7 << 11),
             _line(SYNC_DATA, 0x0042, gap=False), _line(SYNC_DATA, 0x0043, gap=False)]
    rng = random.Random(16)
    base = 1_700_000_000 * 10**9
    irregular = sorted(base + rng.randrange(0, 10**9) for _ in lines)
    spread = [base + i * 2 * 10**9 for i in range(len(lines))]
    runs = [_frame(lines, arrivals) for arrivals in ([base] * len(lines), irregular, spread)]
    for records in runs:
        assert [(str(r.format), r.rt, r.errors, r.data, r.status) for r in records] == [
            ("BC_RT", 5, (), (0x1234, 0xABCD), (5 << 11,)),
            ("RT_BC", 7, ("no_response",), (), ()),
            ("BC_RT", 9, (), (0x0101,), (9 << 11,)),
            ("RT_BC", 7, (), (0x0042, 0x0043), (7 << 11,))]
        assert all(r.gaps_ns in ((), (8_000,)) for r in records)


def test_framer_quiet_link_ends_the_wait_for_a_response() -> None:
    """A command still awaiting its status holds the horizon until the link is seen quiet;
    then the assembler may call it unanswered, and the next word opens a message."""
    framer = LineFramer()
    t0 = framer.place(SYNC_CMD, True, 4 << 11 | 1 << 10 | 1 << 5 | 1, 10**12)
    assert horizon([framer]) == t0 + 19_500  # the status may still come
    framer.quiet()
    held = horizon([framer])
    assert held is not None and held >= t0 + 19_500 + 14_000
    t1 = framer.place(SYNC_CMD, True, 4 << 11, 10**12)  # a status-like word, after the quiet
    assert t1 > held


def test_a_quiet_link_releases_the_last_message() -> None:
    """On the real port: the last message comes out once the link stays empty for idle_s."""
    card = SerialCard(buses=1)
    with SerialMonitor(port=card.path(0), idle_s=0.02) as monitor:
        card.write(0, _line(SYNC_CMD, 4 << 11 | 1 << 10 | 1 << 5 | 1))
        records = _collect(monitor, 1)
    card.close()
    assert records[0].errors == ("no_response",)


def _collect(monitor: SerialMonitor, count: int, timeout: float = 20.0) -> list[MonitorRecord]:
    records = []
    while len(records) < count:
        record = monitor.recv(timeout=timeout)
        assert record is not None, f"only {len(records)} of {count} records"
        records.append(record)
    return records


def test_garbage_is_flagged_and_decoding_goes_on() -> None:
    card = SerialCard(buses=1)
    with SerialMonitor(port=card.path(0), idle_s=0.01) as monitor:
        card.write(0, _bc_rt() + b"\x00\xffgarbage;;;\r" + b"CMDS;D1;P1\r" + _bc_rt(6))
        records = _collect(monitor, 4)
        card.write(0, _line(SYNC_CMD, 7 << 11 | 1 << 10 | 1 << 5 | 1) + _line(SYNC_CMD, 7 << 11)
                   + _line(SYNC_DATA, 0x0042, gap=False, parity=False))
        records += _collect(monitor, 1)
    card.close()
    assert [str(r.format) for r in records] == ["BC_RT", "UNKNOWN", "UNKNOWN", "BC_RT",
                                                "RT_BC"]
    assert records[0].data == (0x1234, 0xABCD) and records[0].status == (5 << 11,)
    assert records[1].errors == ("orphan_words", "sync", "word_error")
    assert monitor.malformed_lines == 2
    assert records[3].rt == 6 and records[3].ok
    assert "parity" in records[4].errors and records[4].data == (0x0042,)
    assert all(r.extra["time_tags"] == "host" for r in records)
    assert records == sorted(records, key=lambda r: r.t_ns)


def test_unplug_records_a_gap_and_reconnects() -> None:
    card = SerialCard(buses=1)
    with SerialMonitor(port=card.path(0), idle_s=0.01, backoff_s=0.01,
                       backoff_max_s=0.05) as monitor:
        card.write(0, _bc_rt(5))
        first = _collect(monitor, 1)
        card.unplug()
        assert card.wait(lambda: monitor.recv(timeout=0.05) is None and bool(monitor.gaps))
        assert monitor.gaps[0].end_ns is None and "read failed" in monitor.gaps[0].reason
        card.replug()
        assert card.wait(lambda: all(r.device is not None for r in monitor._readers))
        card.write(0, _bc_rt(9))
        second = _collect(monitor, 1)
        assert monitor.gaps[0].end_ns is not None
        assert monitor.gaps[0].start_ns <= monitor.gaps[0].end_ns
    card.close()
    assert first[0].rt == 5 and second[0].rt == 9 and second[0].ok


def test_unplug_without_reconnect_ends_the_stream() -> None:
    card = SerialCard(buses=1)
    monitor = SerialMonitor(port=card.path(0), reconnect=False)
    card.write(0, _bc_rt(5))
    assert card.wait(lambda: monitor.lines_read == 4)
    card.unplug()
    assert [r.rt for r in monitor] == [5]
    assert monitor.ended
    monitor.close()
    card.close()


def test_a_line_cut_by_an_unplug_is_counted_malformed() -> None:
    """The half line left when the card is pulled is a flagged word, not silently dropped."""
    card = SerialCard(buses=1)
    monitor = SerialMonitor(port=card.path(0), reconnect=False)
    partial = b"DATA;D0;P1;I0;Hx12"
    card.write(0, _bc_rt(5) + partial)
    assert card.wait(lambda: monitor.bytes_read == len(_bc_rt(5) + partial))
    card.unplug()
    records = list(monitor)
    monitor.close()
    card.close()
    assert monitor.malformed_lines == 1
    assert [str(r.format) for r in records] == ["BC_RT", "UNKNOWN"]
    assert records[0].ok and "orphan_words" in records[1].errors


def test_close_stops_the_reader_threads() -> None:
    card = SerialCard(buses=2)
    monitor = SerialMonitor(port=card.path(0), port_b=card.path(1))
    readers = list(monitor._readers)
    monitor.close()
    monitor.close()
    assert not any(r.is_alive() for r in readers)
    card.close()


def test_open_errors_are_clear() -> None:
    card = SerialCard(buses=1)
    with SerialMonitor(port=card.path(0)), pytest.raises(BackendError, match="busy"):
        SerialMonitor(port=card.path(0))
    card.close()
    with pytest.raises(BackendError, match="does not exist"):
        SerialMonitor(port=card.path(0))
    assert "60-mapr.rules" in explain(PermissionError(13, "Permission denied"), "/dev/ttyUSB0")
    assert "dialout" in explain(PermissionError(13, "Permission denied"), "/dev/ttyUSB0")
    with pytest.raises(BackendError, match="serial number"):
        SerialMonitor(serial_number="no-such-card-0000")
    with pytest.raises(BackendError, match="needs port"):
        SerialMonitor()


def test_registered_as_serial() -> None:
    assert backend_class("serial") is SerialMonitor


def test_a_slow_consumer_loses_nothing() -> None:
    """The reader thread keeps reading into its bounded queue while nobody calls recv()."""
    card = SerialCard(buses=1)
    done: queue.Queue[int] = queue.Queue()
    # idle_s well above any scheduling stall of the writer thread on a loaded machine: a pause
    # longer than idle_s inside a message would (rightly) end its transmission early
    with SerialMonitor(port=card.path(0), idle_s=0.5, queue_chunks=4) as monitor:
        writer = threading.Thread(target=lambda: [card.write(0, _bc_rt(i % 30 + 1))
                                                  for i in range(200)] and done.put(1))
        writer.start()
        records = _collect(monitor, 199)
        writer.join(timeout=20)
    card.close()
    assert [r.rt for r in records] == [i % 30 + 1 for i in range(199)]
    assert all(r.ok for r in records)
