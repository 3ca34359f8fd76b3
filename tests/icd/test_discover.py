"""`mapr icd discover`: a skeleton ICD from traffic that `mapr icd check` accepts as written."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from drivers.chapter10.reader import Chapter10Reader
from drivers.mil1553.record import MonitorRecord, TransferFormat
from drivers.rtstats import TrafficStatistics
from mapr_daemon.icd import loads_icd
from mapr_daemon.icd.discover import skeleton_yaml

SAMPLE = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "chapter10" / \
    "sample.c10"


def mapr(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args],
                          capture_output=True, text=True, timeout=120, check=False)


def cmd(rt: int, tr: str, sa: int, wc: int) -> int:
    return rt << 11 | (tr == "T") << 10 | sa << 5 | (wc & 31)


def rec(t_ns: int, command: int, fmt: TransferFormat = TransferFormat.BC_RT,
        command2: int | None = None) -> MonitorRecord:
    return MonitorRecord(t_ns=t_ns, bus="A", format=fmt, command=command, command2=command2,
                         data=(0,) * (command & 31), status=(0,), gaps_ns=(6000,))


def test_sample_recording_lists_every_rt_sa_pair_and_checks(tmp_path: Path) -> None:
    if not SAMPLE.is_file():
        pytest.skip(f"the sample Chapter 10 recording is not at {SAMPLE}")
    out = tmp_path / "found.yaml"
    result = mapr("icd", "discover", str(SAMPLE), "--output", str(out))
    assert result.returncode == 0, result.stderr
    check = mapr("icd", "check", str(out))
    assert check.returncode == 0 and ": ok: " in check.stdout, check.stderr
    # the pairs counted independently, from the reader's records and their properties
    data: set[tuple[int, str, int]] = set()
    modes: set[tuple[int, str, int]] = set()
    reader = Chapter10Reader(SAMPLE, arinc429=False)
    for batch in reader:
        for r in batch.records:
            assert r.rt is not None and r.tr is not None and r.sa is not None
            if r.mode_code is not None:
                modes.add((r.rt, r.tr, r.mode_code))
            else:
                data.add((r.rt, r.tr, r.sa))
            if r.rt2 is not None and r.sa2 is not None:
                data.add((r.rt2, "T", r.sa2))
    reader.close()
    icd = loads_icd(out.read_text(), str(out))
    listed = {(m.rt, m.tr, m.subaddress) for m in icd.messages}
    listed |= {(m.source[0], "T", m.source[1]) for m in icd.messages if m.source}
    assert listed == data and len(data) == 124
    descriptions = {t.address: t.description for t in icd.terminals}
    assert all(f"{tr} MC{mc:02d}" in descriptions[rt] for rt, tr, mc in modes) and modes


def test_word_counts_rt_rt_conflicts_and_broadcast() -> None:
    records = [rec(0, cmd(1, "R", 2, 4)), rec(10_000_000, cmd(1, "R", 2, 7)),
               rec(20_000_000, cmd(1, "R", 2, 7)),
               # 3 R 5 <- 4 T 6, and 4 T 6 nowhere else: an RT-RT message with a source
               rec(1_000_000, cmd(3, "R", 5, 2), TransferFormat.RT_RT, cmd(4, "T", 6, 2)),
               # 3 R 7 <- 4 T 8, but 4 T 8 also answers the BC: two plain messages
               rec(2_000_000, cmd(3, "R", 7, 2), TransferFormat.RT_RT, cmd(4, "T", 8, 2)),
               rec(3_000_000, cmd(4, "T", 8, 2), TransferFormat.RT_BC),
               rec(4_000_000, cmd(31, "R", 9, 3), TransferFormat.BCAST_BC_RT),
               rec(5_000_000, cmd(9, "T", 0, 2), TransferFormat.MODE)]
    stats = TrafficStatistics()
    stats.add_batch(records)
    text = skeleton_yaml(stats, name="bench", source="hand-built records")
    icd = loads_icd(text, "discovered.yaml")
    by_key = {(m.rt, m.tr, m.subaddress): m for m in icd.messages}
    assert set(by_key) == {(1, "R", 2), (3, "R", 5), (3, "R", 7), (4, "T", 8)}
    assert by_key[(1, "R", 2)].word_count == 7 and "word counts 4-7" in \
        by_key[(1, "R", 2)].description
    assert by_key[(1, "R", 2)].rate_hz == 150       # 3 messages over 20 ms observed
    assert len(by_key[(1, "R", 2)].parameters) == 7
    assert by_key[(3, "R", 5)].source == (4, 6) and by_key[(3, "R", 7)].source is None
    assert "RT03 R SA07 also receives RT-RT from RT04 T SA08" in text
    assert "RT31 R SA09 (broadcast)" in text
    assert {t.address for t in icd.terminals} == {1, 3, 4, 9}
    assert "T MC02 transmit status word x1" in next(
        t.description for t in icd.terminals if t.address == 9)


def test_no_traffic_gives_an_empty_table_that_loads() -> None:
    icd = loads_icd(skeleton_yaml(TrafficStatistics()), "empty.yaml")
    assert icd.messages == () and icd.terminals == ()


def test_live_backend_bounded_by_count(tmp_path: Path) -> None:
    out = tmp_path / "live.yaml"
    result = mapr("icd", "discover", "--backend", "loopback", "--count", "300",
                  "--output", str(out))
    assert result.returncode == 0, result.stderr
    assert mapr("icd", "check", str(out)).returncode == 0
    assert "rt05_t_sa10" in out.read_text()


@pytest.mark.parametrize("args", [["--backend", "loopback"], [], ["x.c10", "--backend", "y"],
                                  ["--backend", "loopback", "--count", "0"]])
def test_misuse_is_one_line_and_exit_2(args: list[str]) -> None:
    result = mapr("icd", "discover", *args)
    assert result.returncode == 2 and len(result.stderr.splitlines()) == 1, result.stderr
