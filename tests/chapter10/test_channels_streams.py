"""Channels are buses, nothing complete is lost, a file says what it holds, streams read.

Recordings are built with the project's own Chapter 10 packet writer
(:mod:`drivers.chapter10.recording_packets`): several 1553 channels interleaved packet by
packet, as a recorder of several buses writes them.
"""

from __future__ import annotations

import json
import subprocess
import sys
from datetime import datetime
from pathlib import Path

import pytest

from drivers.chapter10.reader import Chapter10Reader
from drivers.chapter10.recording_packets import ms1553_packet, time_packet, tmats_packet
from drivers.mil1553.record import MonitorRecord, TransferFormat

ROOT = Path(__file__).resolve().parents[2]
RATE_HZ = 450
SECONDS = 2
WC = 32
"""A BC-RT of 32 words: 34 words with command and status, 680 µs: at 450 Hz, 30.6 % load."""


def _command(rt: int, tr: int, sa: int, wc: int) -> int:
    return rt << 11 | tr << 10 | sa << 5 | (wc & 31)


def _records(channel: int) -> list[MonitorRecord]:
    """One bus's traffic: RT ``channel`` receives 32 words on SA 1 at 450 Hz, on bus A."""
    period = 1_000_000_000 // RATE_HZ
    return [MonitorRecord(t_ns=i * period + channel * 1000, bus="A",
                          format=TransferFormat.BC_RT, command=_command(channel, 0, 1, WC),
                          data=tuple(range(WC)), status=(channel << 11,), gaps_ns=(8000,),
                          end_ns=i * period + channel * 1000 + 34 * 20_000)
            for i in range(RATE_HZ * SECONDS)]


def _packets(channels: list[int], per_packet: int = 45) -> list[bytes]:
    """TMATS, a time packet, then each channel's 1553 packets interleaved (100 ms each)."""
    out = [tmats_packet(0, "G\\DSI\\N:0;", 1),
           time_packet(100, 0, 0, datetime(2024, 5, 1, 12, 0, 0))]
    records = {c: _records(c) for c in channels}
    for start in range(0, RATE_HZ * SECONDS, per_packet):
        for c in channels:
            out.append(ms1553_packet(c, start // per_packet, records[c][start:start + per_packet]))
    return out


def _write(path: Path, packets: list[bytes]) -> Path:
    path.write_bytes(b"".join(packets))
    return path


def _mapr(*args: str, stdin: Path | None = None) -> subprocess.CompletedProcess[str]:
    source = stdin.read_bytes() if stdin else b""
    run = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args],
                         input=source, capture_output=True, cwd=ROOT,
                         env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}, check=False)
    return subprocess.CompletedProcess(run.args, run.returncode, run.stdout.decode(),
                                       run.stderr.decode())


@pytest.fixture(scope="module")
def three_buses(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _write(tmp_path_factory.mktemp("c10") / "three.c10", _packets([3, 4, 5]))


def test_stats_are_per_channel_each_bus_its_own_load_and_rate(three_buses: Path) -> None:
    run = _mapr("decode", str(three_buses), "--stats", "json")
    assert run.returncode == 0, run.stderr
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    rows = [r for r in lines if r["kind"] == "rtsa"]
    assert sorted((r["channel"], r["rt"]) for r in rows) == [(3, 3), (4, 4), (5, 5)]
    for row in rows:
        assert row["messages"] == RATE_HZ * SECONDS
        assert row["rate_hz"] == pytest.approx(RATE_HZ, rel=0.01)
        assert row["response_us"]["mean"] == pytest.approx(8.0)
    loads = [r for r in lines if r["kind"] == "bus_load"]
    assert {r["channel"] for r in loads} == {3, 4, 5}
    for load in loads:   # each bus ~30 %, not the 92 % of three buses added together
        assert load["bus"] == "A" and 29 < load["load_percent"] < 32


def test_stats_text_has_a_table_per_channel(three_buses: Path) -> None:
    run = _mapr("decode", str(three_buses), "--stats", "--c10-channel", "4")
    assert run.returncode == 0, run.stderr
    assert "channel 4 (1553)" in run.stdout and "channel 3" not in run.stdout
    assert "RT04 R SA01" in run.stdout


def test_text_view_has_a_channel_column(three_buses: Path) -> None:
    run = _mapr("decode", str(three_buses), "--text")
    assert run.returncode == 0, run.stderr
    head, *lines = run.stdout.splitlines()
    assert head.split()[:3] == ["time_s", "ch", "bus"]
    assert len(lines) == 3 * RATE_HZ * SECONDS
    assert {line.split()[1] for line in lines} == {"3", "4", "5"}
    assert all(line.split()[4] == f"{line.split()[1].zfill(2)}-01" for line in lines[:300])


def test_no_1553_data_says_what_the_file_holds(tmp_path: Path) -> None:
    path = _write(tmp_path / "time_only.c10", _packets([])[:2])
    for args in (["decode", str(path)], ["decode", str(path), "--stats"]):
        run = _mapr(*args)
        assert run.returncode == 65
        assert run.stdout == ""
        assert run.stderr.count("\n") == 1
        assert "no MIL-STD-1553 data" in run.stderr and "TMATS channel 0" in run.stderr
        assert "time channel 100" in run.stderr


def test_an_absent_channel_names_the_channels_there(three_buses: Path) -> None:
    run = _mapr("decode", str(three_buses), "--c10-channel", "9")
    assert run.returncode == 65
    assert "channel 9 not in the recording" in run.stderr and "1553 channels 3, 4, 5" in run.stderr


def test_a_stream_on_stdin_reads_as_the_file(three_buses: Path) -> None:
    from_file = _mapr("decode", str(three_buses), "--c10-channel", "5")
    from_stdin = _mapr("decode", "-", "--c10-channel", "5", stdin=three_buses)
    assert from_stdin.returncode == 0, from_stdin.stderr
    assert from_stdin.stdout == from_file.stdout and from_file.stdout.count("\n") == 900


def test_errors_on_stdin_name_stdin(tmp_path: Path) -> None:
    path = _write(tmp_path / "cut.c10", _packets([3]))
    cut = tmp_path / "cut_short.c10"
    cut.write_bytes(path.read_bytes()[:-100])
    run = _mapr("decode", "-", stdin=cut)
    assert "mapr decode: stdin: offset" in run.stderr


def _cut_recording(tmp_path: Path, cut_packet: int) -> tuple[Path, int]:
    """Ten packets of 81 messages on channel 3; packet ``cut_packet`` (-1: the last) cut 7
    bytes into its 42nd message, the packets after it kept. Returns the file and the offset
    of the cut packet."""
    records = _records(3)[:810]
    packets = [ms1553_packet(3, i, records[i * 81:(i + 1) * 81]) for i in range(10)]
    message_bytes = 14 + 2 * (WC + 2)
    index = cut_packet % 10
    packets[index] = packets[index][:24 + 4 + 41 * message_bytes + 7]
    head = _packets([])
    offset = sum(map(len, head + packets[:index]))
    return _write(tmp_path / "cut.c10", head + packets), offset


@pytest.mark.parametrize("where", [-1, 4], ids=["end of file", "mid-file"])
def test_a_cut_packet_keeps_every_whole_message(tmp_path: Path, where: int) -> None:
    path, offset = _cut_recording(tmp_path, where)
    reader = Chapter10Reader(path)
    out = sum(len(batch.records) for batch in reader)
    assert out == 9 * 81 + 41   # pychapter10 stops at the cut packet's start
    assert len(reader.issues) == 1
    issue = reader.issues[0]
    assert issue.offset == offset
    assert "cut short" in issue.text and "41 whole 1553 messages" in issue.text
    run = _mapr("decode", str(path), "--text")
    assert run.stdout.count("\n") == 1 + 9 * 81 + 41
    assert run.stderr.count("\n") == 1 and f"offset {offset}:" in run.stderr
