"""Terminals on Chapter 10 channels: each 1553 channel of a recording is a bus of its own.

``mapr icd discover`` of a recording of eight buses (each carrying the same messages at
450 Hz, RT-RT transfers included) writes each channel's terminals with ``channel: N`` and
rates of 450 Hz, not the 3600 Hz of eight buses merged; ``decode --icd`` with that table
gives each message its own channel's values; a bad ``channel`` line in the YAML is one line
naming the file and line.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.errors import IcdError
from mapr_daemon.icd import loads_icd
from tests.support.cli_run import mapr
from tests.support.multibus import RATE_HZ, SECONDS, write_recording

ROOT = Path(__file__).resolve().parents[2]
CHANNELS = list(range(1, 9))




@pytest.fixture(scope="module")
def eight_buses(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_recording(tmp_path_factory.mktemp("c10") / "eight.c10", CHANNELS)


@pytest.fixture(scope="module")
def discovered(eight_buses: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("icd") / "found.yaml"
    run = mapr("icd", "discover", str(eight_buses), "-o", str(out))
    assert run.returncode == 0, run.stderr
    assert "on 8 channels" in run.stderr
    return out


def test_discover_gives_each_channel_its_terminals_and_rates(discovered: Path) -> None:
    check = mapr("icd", "check", str(discovered))
    assert check.returncode == 0 and ": ok: 16 terminals, 24 messages" in check.stdout
    icd = loads_icd(discovered.read_text(), str(discovered))
    assert icd.channels == tuple(CHANNELS)
    assert {(t.channel, t.address) for t in icd.terminals} == {
        (c, a) for c in CHANNELS for a in (5, 6)}
    for message in icd.messages:   # 450 Hz on each bus, not 8 x 450
        assert message.rate_hz == pytest.approx(RATE_HZ, rel=0.01)
        assert message.name.startswith(f"ch{message.channel}_")
    rt_rt = [m for m in icd.messages if m.source is not None]
    assert sorted((m.channel, m.rt, m.subaddress, m.source) for m in rt_rt) == [
        (c, 5, 4, (6, 3)) for c in CHANNELS]


def test_discover_of_one_channel_is_a_table_for_any_bus(eight_buses: Path) -> None:
    run = mapr("icd", "discover", str(eight_buses), "--c10-channel", "3")
    assert run.returncode == 0, run.stderr
    icd = loads_icd(run.stdout)
    assert icd.channels == () and len(icd.messages) == 3
    assert all(m.rate_hz == pytest.approx(RATE_HZ, rel=0.01) for m in icd.messages)


def test_discover_reads_a_stream_on_stdin(eight_buses: Path) -> None:
    from_file = mapr("icd", "discover", str(eight_buses), "--c10-channel", "2",
                     "--c10-channel", "5")
    from_stdin = mapr("icd", "discover", "-", "--c10-channel", "2", "--c10-channel", "5",
                      stdin=eight_buses.read_bytes())
    assert from_stdin.returncode == 0, from_stdin.stderr
    assert from_stdin.stdout == from_file.stdout.replace(str(eight_buses), "stdin")
    assert "channel: 5" in from_stdin.stdout


def test_discover_names_an_absent_channel(eight_buses: Path) -> None:
    run = mapr("icd", "discover", "-", "--c10-channel", "9", stdin=eight_buses.read_bytes())
    assert run.returncode == 65 and run.stdout == ""
    assert run.stderr.startswith("mapr icd discover: stdin: channel 9 not in the recording")


def test_decode_icd_matches_each_message_on_its_own_channel(eight_buses: Path,
                                                            discovered: Path) -> None:
    run = mapr("decode", str(eight_buses), "--icd", str(discovered))
    assert run.returncode == 0, run.stderr
    lines = [json.loads(line) for line in run.stdout.splitlines()]
    assert len(lines) == 3 * RATE_HZ * SECONDS * len(CHANNELS)
    for line in lines:
        values = line["values"]
        assert values["message"].startswith(f"ch{line['channel']}_")
        assert values[values["message"] + "_w00"] == line["channel"]   # word 0: the channel


TABLE = """\
spec: 1
name: two buses
terminals:
  - {address: 5, name: left_rt05, channel: 1}
  - {address: 6, name: left_rt06, channel: 1}
  - {address: 5, name: right_rt05, channel: 2}
messages:
  - {name: left_fwd, rt: left_rt05, tr: R, sa: 4, wc: 1, rate_hz: 0,
     source: {rt: left_rt06, sa: 3}, parameters: [{name: a, word: 0, type: unsigned}]}
  - {name: right_status, rt: right_rt05, tr: T, sa: 2, wc: 1, rate_hz: 0,
     parameters: [{name: b, word: 0, type: unsigned}]}
"""


def _record(channel: int | None, command: int, command2: int | None = None) -> MonitorRecord:
    fmt = TransferFormat.RT_BC if command2 is None else TransferFormat.RT_RT
    return MonitorRecord(t_ns=0, bus="A", format=fmt, command=command, command2=command2,
                         data=(1,), status=(0,), gaps_ns=(8000,),
                         extra={} if channel is None else {"channel": channel})


def test_a_message_on_a_channel_matches_that_channel_only() -> None:
    icd = loads_icd(TABLE)
    status = 5 << 11 | 1 << 10 | 2 << 5 | 1
    assert icd.match(_record(2, status)) is icd.message("right_status")
    assert icd.match(_record(1, status)) is None
    assert icd.match(_record(None, status)) is None
    forward = (5 << 11 | 4 << 5 | 1, 6 << 11 | 1 << 10 | 3 << 5 | 1)
    assert icd.match(_record(1, *forward)) is icd.message("left_fwd")
    assert icd.match(_record(2, *forward)) is None
    assert icd.lookup(5, "T", 2, channel=2) is icd.message("right_status")
    result = icd.decode_batch([_record(2, status), _record(1, status)])
    assert result.records == {"right_status": 1} and result.unmatched == 1


@pytest.mark.parametrize(("terminal", "problem"), [
    ("{address: 5, name: right_rt05, channel: 0}", "terminals[2].channel: 0 is outside 1..65534"),
    ("{address: 5, name: right_rt05, channel: 1}", "address 5 on channel 1 already used"),
    ("{address: 5, name: right_rt05}", "address 5 already used by the terminal on line 4"),
])
def test_bad_channels_are_one_line_with_file_and_line(terminal: str, problem: str) -> None:
    text = TABLE.replace("{address: 5, name: right_rt05, channel: 2}", terminal)
    with pytest.raises(IcdError) as caught:
        loads_icd(text, "two.yaml")
    message = str(caught.value)
    assert "\n" not in message and message.startswith("two.yaml:6: ")
    assert problem in message


def test_an_rt_rt_source_on_another_bus_and_an_ambiguous_address_are_refused() -> None:
    other_bus = TABLE.replace("source: {rt: left_rt06", "source: {rt: right_rt05")
    with pytest.raises(IcdError, match=r"^<string>:9: .*an RT-RT transfer is on one bus"):
        loads_icd(other_bus)
    by_address = TABLE.replace("rt: right_rt05, tr: T", "rt: 5, tr: T")
    with pytest.raises(IcdError, match=r"address 5 is the terminal of several channels "
                                       r"\(left_rt05 on channel 1, right_rt05 on channel 2\)"):
        loads_icd(by_address)


def test_a_bad_channel_in_a_file_exits_78_naming_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(TABLE.replace("channel: 2}", "channel: two}"))
    run = mapr("icd", "check", str(path))
    assert run.returncode == 78
    assert run.stderr.count("\n") == 1 and f"{path}:6:" in run.stderr
