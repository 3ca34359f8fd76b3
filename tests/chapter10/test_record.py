"""``mapr record``: a backend's traffic into a Chapter 10 file, stopped every way a user can."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from chapter10 import C10
from chapter10.ms1553 import MS1553F1
from chapter10.time import TimeF1

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
SUMMARY = re.compile(r"recorded (\d+) messages \((\d+) with errors\) in (\d+) packets, "
                     r"(\d+) bytes to (.+)")


def _in_file(path: Path) -> tuple[int, int, set[int]]:
    """(1553 messages, packets, channel ids) as pychapter10 reads the file."""
    messages = packets = 0
    channels = set()
    for packet in C10(str(path)):
        packets += 1
        channels.add(packet.channel_id)
        if isinstance(packet, MS1553F1):
            messages += len(list(packet))
    return messages, packets, channels


def _summary(text: str) -> tuple[int, int, int, int, str]:
    found = SUMMARY.search(text)
    assert found, text
    messages, errors, packets, size, path = found.groups()
    return int(messages), int(errors), int(packets), int(size), path


def test_records_a_bounded_source_to_its_end(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "loop.c10"
    code = main(["record", "--backend", "loopback", "-O", "frames=200", "-O", "bit_level=false",
                 str(out)])
    assert code == exitcodes.OK
    messages, errors, packets, size, path = _summary(capsys.readouterr().out)
    assert path == str(out)
    assert size == out.stat().st_size
    assert errors == 0
    assert (messages, packets) == _in_file(out)[:2]
    assert messages > 200


def test_count_stops_after_that_many_messages(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "count.c10"
    assert main(["record", "--backend", "loopback", "-O", "bit_level=false", "--count", "25",
                 str(out)]) == exitcodes.OK
    assert _summary(capsys.readouterr().out)[0] == 25
    assert _in_file(out)[0] == 25


def test_duration_stops_a_live_source(tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "duration.c10"
    assert main(["record", "--backend", "loopback", "-O", "realtime=true", "-O",
                 "bit_level=false", "--duration", "0.5", str(out)]) == exitcodes.OK
    messages = _summary(capsys.readouterr().out)[0]
    assert messages > 0
    assert _in_file(out)[0] == messages


def test_channel_option_sets_the_1553_and_time_channels(tmp_path: Path) -> None:
    out = tmp_path / "channel.c10"
    assert main(["record", "--backend", "loopback", "-O", "frames=10", "-O", "bit_level=false",
                 "--channel", "9", str(out)]) == exitcodes.OK
    assert _in_file(out)[2] == {0, 9, 10}
    assert any(isinstance(p, TimeF1) and p.channel_id == 10 for p in C10(str(out)))


@pytest.mark.parametrize(("argv", "code", "message"), [
    (["--backend", "loopback", "-O", "nosuch=1"], exitcodes.USAGE, "unknown option"),
])
def test_a_backend_that_cannot_be_opened_is_one_line(tmp_path: Path, argv: list[str],
                                                     code: int, message: str,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "never.c10"
    assert main(["record", *argv, str(out)]) == code
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_an_output_that_cannot_be_written_is_one_line_naming_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "no" / "such" / "dir.c10"
    assert main(["record", "--backend", "loopback", str(out)]) == exitcodes.USAGE
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"mapr record: cannot write {out}:") and "\n" not in err


@pytest.mark.parametrize("argv", [["--channel", "0"], ["-o", "novalue"], ["--count", "x"],
                                  ["--backend", "nosuch"]])
def test_bad_arguments_exit_2(tmp_path: Path, argv: list[str]) -> None:
    with pytest.raises(SystemExit) as stopped:
        main(["record", *argv, str(tmp_path / "x.c10")])
    assert stopped.value.code == exitcodes.USAGE


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_stops_recording_with_every_message_in_the_file(tmp_path: Path,
                                                                 signum: int) -> None:
    out = tmp_path / "signal.c10"
    process = subprocess.Popen(
        [sys.executable, "-m", "mapr_daemon.cli.main", "record", "--backend", "loopback",
         "-O", "realtime=true", "-O", "bit_level=false", str(out)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 60
        while not (out.exists() and _has_1553(out)):
            assert process.poll() is None, process.communicate()
            assert time.monotonic() < deadline, "no 1553 packet written within 60 s"
            time.sleep(0.1)
        process.send_signal(signum)
        stdout, stderr = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == exitcodes.INTERRUPTED, stderr
    messages, _, packets, size, _ = _summary(stdout)
    assert "Traceback" not in stderr
    assert (messages, packets) == _in_file(out)[:2]
    assert size == out.stat().st_size


def _has_1553(path: Path) -> bool:
    return any(isinstance(p, MS1553F1) for p in C10(str(path)))


def test_a_recording_made_with_a_tail_is_read_back_with_that_tail(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``mapr record --tail`` writes the tail number into TMATS, where ``mapr fleet
    --tail-tmats 'G\\TA'`` finds each recording's tail (the file's folder says otherwise)."""
    from drivers.chapter10.tmats import TAIL_ATTRIBUTE
    from mapr_daemon.fleet.archive import discover

    out = tmp_path / "box7" / "rec-0003.c10"
    out.parent.mkdir()
    assert main(["record", "--backend", "loopback", "-O", "bit_level=false", "--count", "25",
                 "--tail", "N777AB", str(out)]) == exitcodes.OK
    plain = tmp_path / "box7" / "rec-0004.c10"
    assert main(["record", "--backend", "loopback", "-O", "bit_level=false", "--count", "25",
                 str(plain)]) == exitcodes.OK
    found, bad = discover([tmp_path], tail_tmats=TAIL_ATTRIBUTE)
    assert [(r.tail, r.flight) for r in found] == [("N777AB", 3), ("box7", 4)] and not bad
    assert [r.tail for r in discover([tmp_path])[0]] == ["box7", "box7"]


def test_a_tail_tmats_cannot_hold_is_refused_before_the_file(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "bad.c10"
    assert main(["record", "--backend", "loopback", "-O", "bit_level=false", "--count", "5",
                 "--tail", "N1;G\\PN:X", str(out)]) == exitcodes.USAGE
    assert "--tail" in capsys.readouterr().err and not out.exists()
