"""Chapter10Writer: what pychapter10 (an independent reader) finds in a recording."""

from __future__ import annotations

import os
import struct
import subprocess
import sys
from collections import Counter
from datetime import UTC, datetime, timedelta, timezone
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from chapter10 import C10
from chapter10.computer import ComputerF1
from chapter10.ms1553 import MS1553F1
from chapter10.time import TimeF1

from drivers.backends.loopback import Injection, LoopbackMonitor
from drivers.chapter10.status import errors_for
from drivers.chapter10.tmats import parse_tmats
from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord, TransferFormat

START = datetime(2026, 3, 14, 15, 9, 26, 530000)


def _loopback_records(frames: int = 60) -> list[MonitorRecord]:
    """The default loopback traffic (all ten formats) with errors injected at bit level."""
    injections = [
        Injection("no_response", rt=5, sa=10),
        Injection("word_count_low", rt=5, sa=1),
        Injection("manchester", rt=5, sa=2),
        Injection("parity", rt=6, sa=1, word=3),
        Injection("no_response", format="RT_RT", responder=1),
    ]
    with LoopbackMonitor(frames=frames, injections=injections) as monitor:
        return list(monitor)


def _packets(path: Path) -> list[Any]:
    """Every packet pychapter10 reads, with its messages read out (headers are validated
    by pychapter10 as it reads: sync pattern and header checksum)."""
    packets = []
    for packet in C10(str(path)):
        if isinstance(packet, MS1553F1):
            packet.messages = list(packet)
        packets.append(packet)
    return packets


def _raw_packets(path: Path) -> list[bytes]:
    """The file cut into packets by the header's packet length, independently of pychapter10."""
    data = path.read_bytes()
    out, offset = [], 0
    while offset < len(data):
        assert data[offset:offset + 2] == b"\x25\xeb", f"no sync at {offset}"
        length = struct.unpack_from("<I", data, offset + 4)[0]
        out.append(data[offset:offset + length])
        offset += length
    assert offset == len(data)
    return out


def _record(t_ns: int, *, fmt: TransferFormat = TransferFormat.RT_BC, command: int = 0x2C22,
            data: tuple[int, ...] = (1, 2), status: tuple[int, ...] = (0x2800,),
            gaps_ns: tuple[int, ...] = (6_000,), bus: str = "A",
            errors: tuple[str, ...] = ()) -> MonitorRecord:
    return MonitorRecord(t_ns=t_ns, bus=bus, format=fmt, command=command, data=data,
                         status=status, gaps_ns=gaps_ns, errors=errors)


@pytest.fixture(scope="module")
def traffic() -> list[MonitorRecord]:
    return _loopback_records()


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory, traffic: list[MonitorRecord]) -> Path:
    path = tmp_path_factory.mktemp("rec") / "loopback.c10"
    with Chapter10Writer(path, channel_id=3, start_time=START) as writer:
        writer.write(traffic)
    return path


def test_packets_are_tmats_then_time_then_1553_on_their_channels(recording: Path,
                                                                  traffic: list[Any]) -> None:
    packets = _packets(recording)
    assert isinstance(packets[0], ComputerF1) and packets[0].channel_id == 0
    assert packets[0].data_type == 0x01
    assert isinstance(packets[1], TimeF1) and packets[1].channel_id == 4
    assert packets[1].data_type == 0x11
    kinds = Counter((type(p).__name__, p.channel_id, p.data_type) for p in packets)
    assert set(kinds) == {("ComputerF1", 0, 0x01), ("TimeF1", 4, 0x11), ("MS1553F1", 3, 0x19)}
    assert kinds[("ComputerF1", 0, 0x01)] == 1
    messages = [m for p in packets if isinstance(p, MS1553F1) for m in p.messages]
    assert len(messages) == len(traffic)
    assert sum(p.count for p in packets if isinstance(p, MS1553F1)) == len(traffic)


def test_tmats_says_which_channel_is_the_1553_bus(recording: Path) -> None:
    tmats = _packets(recording)[0]
    assert tmats.version == 7
    attributes = parse_tmats(tmats.data.decode("ascii"))
    assert attributes["G\\106"] == "07"
    assert attributes["R-1\\N"] == "2"
    assert attributes["R-1\\TK1-2"] == "3" and attributes["R-1\\CDT-2"] == "1553IN"
    assert attributes["R-1\\TK1-1"] == "4" and attributes["R-1\\CDT-1"] == "TIMEIN"
    assert attributes["B-1\\BT-1"] == "1553"
    assert attributes["R-1\\CDLN-2"] == attributes["B-1\\DLN"]
    assert attributes["G\\OD"] == "03-14-2026"


def test_every_message_holds_its_record(recording: Path, traffic: list[MonitorRecord]) -> None:
    """Time stamp, bus, block status, gaps and the words in bus order, message by message."""
    messages = [m for p in _packets(recording) if isinstance(p, MS1553F1) for m in p.messages]
    for record, message in zip(traffic, messages, strict=True):
        assert message.ipts == round(record.t_ns / 100)
        assert message.bus == (record.bus == "B")
        assert message.rt2rt == (record.format in (TransferFormat.RT_RT,
                                                   TransferFormat.BCAST_RT_RT))
        words = list(struct.unpack(f"<{message.length // 2}H", message.data))
        assert message.length == 2 * len(words)
        commands = [c for c in (record.command, record.command2) if c is not None]
        assert words[:len(commands)] == commands
        assert sorted(words[len(commands):]) == sorted([*record.data, *record.status])
        gaps = [round(g / 100) for g in record.gaps_ns] + [0, 0]
        assert message.gap_time == gaps[0] | gaps[1] << 8
        assert message.me == bool(record.errors)
        status = (message.bus << 13 | message.me << 12 | message.rt2rt << 11 | message.fe << 10
                  | message.timeout << 9 | message.le << 5 | message.se << 4 | message.we << 3)
        if "no_response" in record.errors:
            assert "no_response" in errors_for(status)
        if {"parity", "manchester"} & set(record.errors):
            assert "word_error" in errors_for(status)
        if "word_count_low" in record.errors:
            assert message.le


def test_the_errors_injected_are_in_the_file(recording: Path) -> None:
    messages = [m for p in _packets(recording) if isinstance(p, MS1553F1) for m in p.messages]
    assert sum(m.timeout for m in messages) >= 3
    assert any(m.we for m in messages)
    assert any(m.le for m in messages)
    assert any(m.rt2rt and m.timeout for m in messages)


def test_words_are_in_bus_order_for_each_format() -> None:
    from drivers.chapter10.recording_packets import words_in_bus_order
    rt_rt = MonitorRecord(0, "A", TransferFormat.RT_RT, command=0x2862, command2=0x3422,
                          data=(7, 8), status=(0x3000, 0x2800))
    assert words_in_bus_order(rt_rt) == [0x2862, 0x3422, 0x3000, 7, 8, 0x2800]
    bc_rt = MonitorRecord(0, "A", TransferFormat.BC_RT, command=0x2822, data=(7, 8),
                          status=(0x2800,))
    assert words_in_bus_order(bc_rt) == [0x2822, 7, 8, 0x2800]
    rt_bc = MonitorRecord(0, "A", TransferFormat.RT_BC, command=0x2C22, data=(7, 8),
                          status=(0x2800,))
    assert words_in_bus_order(rt_bc) == [0x2C22, 0x2800, 7, 8]
    silent = MonitorRecord(0, "A", TransferFormat.RT_BC, command=0x2C22,
                           errors=("no_response",))
    assert words_in_bus_order(silent) == [0x2C22]
    mode_tx = MonitorRecord(0, "A", TransferFormat.MODE_TX_DATA, command=0x2C13, data=(5,),
                            status=(0x2800,))
    assert words_in_bus_order(mode_tx) == [0x2C13, 0x2800, 5]


def test_checksums_and_alignment_hold_for_every_packet(recording: Path) -> None:
    for raw in _raw_packets(recording):
        assert len(raw) % 4 == 0
        header = np.frombuffer(raw[:24], dtype="<u2")
        assert int(header[:-1].sum()) & 0xFFFF == int(header[-1])
        assert raw[14] & 0x03 == 3, "32-bit data checksum flag"
        body = np.frombuffer(raw[24:-4], dtype="<u4")
        stored = struct.unpack_from("<I", raw, len(raw) - 4)[0]
        assert int(body.sum(dtype=np.uint64)) & 0xFFFFFFFF == stored
        data_length = struct.unpack_from("<I", raw, 8)[0]
        assert data_length <= len(raw) - 28


def test_sequence_numbers_count_per_channel(tmp_path: Path) -> None:
    path = tmp_path / "seq.c10"
    # 3 s of messages every 20 ms: 1553 packets of 100 ms, a time packet each second.
    with Chapter10Writer(path, start_time=START) as writer:
        writer.write(_record(t) for t in range(0, 3_000_000_000, 20_000_000))
    sequences: dict[int, list[int]] = {}
    for packet in _packets(path):
        sequences.setdefault(packet.channel_id, []).append(packet.sequence_number)
    assert sequences[0] == [0]
    assert sequences[2] == [0, 1, 2]
    assert sequences[1] == list(range(len(sequences[1])))
    assert len(sequences[1]) == 30


def test_time_packets_every_second_tie_the_counter_to_the_start(tmp_path: Path) -> None:
    path = tmp_path / "time.c10"
    with Chapter10Writer(path, start_time=START) as writer:
        writer.write(_record(t) for t in range(0, 3_500_000_000, 50_000_000))
    times = [(p.rtc, p.time) for p in _packets(path) if isinstance(p, TimeF1)]
    assert times == [(k * 10_000_000, START + timedelta(seconds=k)) for k in range(4)]


def test_start_time_is_utc_truncated_to_the_time_packets_10_ms(tmp_path: Path) -> None:
    path = tmp_path / "zone.c10"
    local = datetime(2026, 3, 14, 17, 9, 26, 538_765, tzinfo=timezone(timedelta(hours=2)))
    with Chapter10Writer(path, start_time=local) as writer:
        assert writer.start_time == datetime(2026, 3, 14, 15, 9, 26, 530_000)
    first_time = next(p for p in _packets(path) if isinstance(p, TimeF1))
    assert first_time.time == datetime(2026, 3, 14, 15, 9, 26, 530_000)


def test_default_start_is_the_wall_clock(tmp_path: Path) -> None:
    before = datetime.now(UTC).replace(tzinfo=None) - timedelta(milliseconds=10)
    with Chapter10Writer(tmp_path / "now.c10") as writer:
        pass
    after = datetime.now(UTC).replace(tzinfo=None)
    assert before <= writer.start_time <= after


def test_packets_span_at_most_100_ms_and_the_time_tag_bits_say_first_bit(tmp_path: Path
                                                                         ) -> None:
    path = tmp_path / "span.c10"
    with Chapter10Writer(path, start_time=START) as writer:
        writer.write(_record(t) for t in range(0, 1_000_000_000, 7_000_000))
    packets = [p for p in _packets(path) if isinstance(p, MS1553F1)]
    for packet in packets:
        stamps = [m.ipts for m in packet.messages]
        assert packet.rtc == stamps[0]
        assert stamps[-1] - stamps[0] < 1_000_000
    raw = [r for r in _raw_packets(path) if r[15] == 0x19]
    assert {struct.unpack_from("<I", r, 24)[0] >> 30 for r in raw} == {1}


def test_a_packet_is_bounded_in_bytes_on_a_busy_bus(tmp_path: Path) -> None:
    path = tmp_path / "busy.c10"
    full = tuple(range(32))
    with Chapter10Writer(path, start_time=START) as writer:
        writer.write(_record(t, data=full) for t in range(0, 90_000_000, 50_000))
    lengths = [len(r) for r in _raw_packets(path) if r[15] == 0x19]
    assert len(lengths) > 1
    assert max(lengths) <= 65_536 + 24 + 4 + 8


def test_gaps_round_to_tenths_and_clamp_at_25_5_us(tmp_path: Path) -> None:
    path = tmp_path / "gaps.c10"
    record = _record(0, fmt=TransferFormat.RT_RT, command=0x2862, status=(0x3000, 0x2800),
                     gaps_ns=(6_049, 30_000))
    with Chapter10Writer(path, start_time=START) as writer:
        writer.write([record])
    message = next(p for p in _packets(path) if isinstance(p, MS1553F1)).messages[0]
    assert message.gap_time == 60 | 255 << 8


def test_close_loses_nothing_and_write_after_close_fails(tmp_path: Path) -> None:
    path = tmp_path / "close.c10"
    writer = Chapter10Writer(path, start_time=START)
    writer.write([_record(1_000), _record(2_000)])
    writer.close()
    writer.close()
    assert writer.stats.messages == 2
    assert writer.stats.bytes == path.stat().st_size
    assert sum(p.count for p in _packets(path) if isinstance(p, MS1553F1)) == 2
    with pytest.raises(ValueError, match="closed"):
        writer.write([_record(3_000)])


def test_a_crash_loses_at_most_the_open_packet(tmp_path: Path) -> None:
    """A process killed mid-recording (no close, no flush): every closed packet is in the
    file and readable; only the messages of the last 100 ms are gone."""
    path = tmp_path / "crash.c10"
    script = (
        "import os, sys\n"
        "from datetime import datetime\n"
        "from drivers.chapter10.writer import Chapter10Writer\n"
        "from drivers.mil1553.record import MonitorRecord, TransferFormat\n"
        "w = Chapter10Writer(sys.argv[1], start_time=datetime(2026, 1, 1))\n"
        "w.write(MonitorRecord(t, 'A', TransferFormat.RT_BC, 0x2C22, (1, 2), (0x2800,))\n"
        "        for t in range(0, 1_000_000_000, 1_000_000))\n"
        "os._exit(9)\n"
    )
    done = subprocess.run([sys.executable, "-c", script, str(path)], check=False,
                          cwd=Path(__file__).resolve().parents[2])
    assert done.returncode == 9
    stamps = [m.ipts for p in _packets(path) if isinstance(p, MS1553F1) for m in p.messages]
    assert stamps == list(range(0, len(stamps) * 10_000, 10_000))
    assert 1_000 - 100 <= len(stamps) < 1_000


def test_records_reach_the_disk_on_flush(tmp_path: Path) -> None:
    path = tmp_path / "flush.c10"
    with Chapter10Writer(path, start_time=START) as writer:
        writer.write([_record(5_000)])
        before = path.stat().st_size
        writer.flush()
        assert path.stat().st_size > before
        assert os.path.getsize(path) == writer.stats.bytes


def test_channel_id_is_checked(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="channel_id"):
        Chapter10Writer(tmp_path / "bad.c10", channel_id=0)


def test_after_an_hour_of_silence_only_the_resuming_seconds_time_packet_is_written(
        tmp_path: Path) -> None:
    path = tmp_path / "silence.c10"
    two_hours = 7_200_000_000_000
    with Chapter10Writer(path, start_time=START) as writer:
        writer.write([_record(0), _record(two_hours + 300_000_000)])
    times = [(p.rtc, p.time) for p in _packets(path) if isinstance(p, TimeF1)]
    assert times == [(0, START), (72_000_000_000, START + timedelta(hours=2))]
    stamps = [m.ipts for p in _packets(path) if isinstance(p, MS1553F1) for m in p.messages]
    assert stamps == [0, 72_003_000_000]
