"""What a bus engineer types wrong, each answered by one line on stderr and the exit code of
docs/cli.md's table (2 bad argument or input, 65 input not there, 69 device unavailable,
78 config error), never a hang or a traceback. Each case runs ``mapr`` as a subprocess
bounded by a timeout.

"No libusb" is a machine without the library: a ``sitecustomize`` on the child's path makes
the library lookup find nothing, as it finds nothing where libusb is not installed.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord, TransferFormat

TIMEOUT_S = 60
"""No case may take longer: a wait on a silent bus would hit it."""

NO_LIBUSB = """\
import ctypes.util
_find = ctypes.util.find_library
ctypes.util.find_library = lambda name: None if "usb" in name else _find(name)
"""


def mapr(*args: str, cwd: Path | None = None, no_libusb: Path | None = None
         ) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ)
    if no_libusb is not None:
        (no_libusb / "sitecustomize.py").write_text(NO_LIBUSB)
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(no_libusb),
                                                          env.get("PYTHONPATH")]))
    return subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args],
                          capture_output=True, text=True, timeout=TIMEOUT_S, cwd=cwd, env=env,
                          check=False)


def one_line(result: subprocess.CompletedProcess[str], code: int, *words: str) -> str:
    """The single stderr line, after checking the exit code and that the line names
    ``words``; nothing on stdout."""
    lines = result.stderr.splitlines()
    assert result.returncode == code, result.stderr
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr and result.stdout == ""
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize(("args", "words"), [
    (["--rt", "40"], ["--rt", "0-31", "40"]),
    (["--sa", "-1"], ["--sa", "0-31", "-1"]),
    (["--format", "XYZ"], ["--format XYZ", "BC_RT"]),
    (["--error", "nosucherr"], ["--error nosucherr", "parity"]),
    (["--tr", "X"], ["--tr X", "T or R"]),
    (["--rt", "5,40"], ["--rt 40", "0-31"]),
    (["--format", "MODE", "--sa", "5"], ["--format MODE", "--sa 5", "never match"]),
    (["--format", "bc_rt", "--tr", "T"], ["--format BC_RT", "--tr T", "never match"]),
    (["--format", "BCAST_BC_RT", "--rt", "4"], ["broadcast", "--rt 4", "never match"]),
    (["--count", "0"], ["--count", ">= 1"]),
    (["--duration", "nan"], ["--duration", "> 0"]),
    (["--backend", "nosuch"], ["--backend", "'nosuch'", "loopback"]),
])
def test_monitor_bad_argument_is_exit_2_before_any_backend(args: list[str],
                                                           words: list[str]) -> None:
    line = one_line(mapr("monitor", *args, "--count", "1") if "--count" not in args
                    else mapr("monitor", *args), 2, *words)
    assert line.startswith("mapr monitor: error: ")


def test_record_bad_channel_and_backend_are_exit_2(tmp_path: Path) -> None:
    out = tmp_path / "x.c10"
    one_line(mapr("record", str(out), "--channel", "0"), 2, "--channel", "1-65534")
    one_line(mapr("record", str(out), "--backend", "nosuch"), 2, "'nosuch'")
    assert not out.exists()


def test_backend_options_it_does_not_take_or_lacks_are_exit_2() -> None:
    one_line(mapr("monitor", "--backend", "capture", "-O", "bogus=1"), 2,
             "unknown option bogus", "path", "sample_rate")
    line = one_line(mapr("monitor", "--backend", "chapter10"), 2, "needs option path",
                    "-O path=")
    assert "__init__" not in line
    one_line(mapr("monitor", "--backend", "chapter10", "-O", "path=x.c10", "-O", "speed=-1"),
             2, "speed")


def test_random_bytes_named_c10_are_not_a_chapter10_file(tmp_path: Path) -> None:
    fake = tmp_path / "flight.c10"
    fake.write_bytes(os.urandom(4096))
    for result in (mapr("decode", str(fake)),
                   mapr("monitor", "--backend", "capture", "-O", f"path={fake}")):
        line = one_line(result, 2, str(fake), "not a Chapter 10 file")
        assert "samplerate" not in line and "sample_rate" not in line


def test_a_raw_capture_without_its_rate_names_the_flag_of_that_command(tmp_path: Path
                                                                        ) -> None:
    raw = tmp_path / "bus.bin"
    raw.write_bytes(bytes(4096))
    assert "-O sample_rate=" in one_line(
        mapr("monitor", "--backend", "capture", "-O", f"path={raw}"), 2, str(raw))
    assert "--samplerate" in one_line(mapr("decode", str(raw)), 2, str(raw))


def test_a_chapter10_channel_not_in_the_recording_is_exit_65_listing_those_that_are(
        tmp_path: Path) -> None:
    recording = tmp_path / "two.c10"
    with Chapter10Writer(recording, channel_id=3) as writer:
        writer.write([MonitorRecord(t_ns=1_000_000 * i, bus="A", format=TransferFormat.BC_RT,
                                    command=(5 << 11) | (1 << 5) | 1, data=(0x1234,),
                                    status=(5 << 11,), end_ns=1_000_000 * i + 60_000)
                      for i in range(1, 3)])
    line = one_line(mapr("decode", str(recording), "--c10-channel", "99"), 65,
                    "channel 99 not in the recording", "1553 channel 3")
    assert line.startswith(f"mapr decode: {recording}")
    kept = mapr("decode", str(recording), "--c10-channel", "3")
    assert kept.returncode == 0 and len(kept.stdout.splitlines()) == 2


def test_a_missing_serial_port_is_exit_69(tmp_path: Path) -> None:
    port = tmp_path / "ttyUSB9"
    one_line(mapr("monitor", "--backend", "serial", "-O", f"port={port}"), 69, str(port))
    out = tmp_path / "x.c10"
    one_line(mapr("record", "--backend", "serial", "-O", f"port={port}", str(out)), 69,
             str(port))
    assert not out.exists()


def test_the_usb_backend_without_libusb_is_one_line_exit_69(tmp_path: Path) -> None:
    for args in (["monitor", "--backend", "usb"],
                 ["record", "--backend", "usb", str(tmp_path / "x.c10")]):
        one_line(mapr(*args, no_libusb=tmp_path), 69, "libusb")


def test_the_daemon_refuses_a_backend_that_can_never_open_exit_69(tmp_path: Path) -> None:
    config = tmp_path / "mapr.yaml"
    config.write_text("log_level: info\nbackend:\n  name: usb\n")
    for args in (["run", "--check", "--config", str(config)],
                 ["run", "--config", str(config)]):
        line = one_line(mapr(*args, no_libusb=tmp_path), 69, f"{config}:3",
                        "backend.name", "libusb")
        assert "retrying" not in line


def test_a_relative_icd_that_is_not_there_names_the_path_tried_and_the_line(
        tmp_path: Path) -> None:
    config = tmp_path / "mapr.yaml"
    config.write_text("log_level: info\nicd: icd/missing.yaml\n")
    one_line(mapr("run", "--check", "--config", str(config), cwd=tmp_path.parent), 78,
             f"{config}:2", "icd", str(tmp_path / "icd" / "missing.yaml"), "no such file")
