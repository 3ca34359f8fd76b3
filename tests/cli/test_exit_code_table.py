"""docs/cli.md's exit-code table (the one README.md points to for exit codes) against what
the commands do: the table lists exactly the codes of ``mapr_daemon.cli.exitcodes``, and for
each code of the table, commands that must end with it are run as a user runs them (a
subprocess, signals included) and do.

Each case is bounded by a generous timeout; none measures time.
"""

from __future__ import annotations

import os
import re
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord, TransferFormat
from mapr_daemon.cli import exitcodes

ROOT = Path(__file__).resolve().parents[2]
TABLE = ROOT / "docs" / "cli.md"
TIMEOUT_S = 120.0
ICD = ROOT / "configs" / "icd" / "ema-testbed.yaml"


def table() -> dict[int, str]:
    """The codes of the table under "Errors and exit codes", with their meaning."""
    text = TABLE.read_text(encoding="utf-8")
    section = text[text.index("## Errors and exit codes"):]
    section = section[:section.index("\n## ", 1)]
    rows = re.findall(r"^\|\s*(\d+)\s*\|([^|]*)\|", section, flags=re.MULTILINE)
    return {int(code): meaning.strip() for code, meaning in rows}


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": str(ROOT)}


def mapr(where: Path, *args: str) -> int:
    done = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args], cwd=where,
                          env=_env(), capture_output=True, text=True, timeout=TIMEOUT_S)
    assert "Traceback" not in done.stderr or done.returncode == exitcodes.FAILURE, \
        done.stderr
    return done.returncode


def stopped(where: Path, signum: signal.Signals, ready: Callable[[str, str], bool],
            *args: str) -> int:
    """Start ``mapr ARGS``, wait until ``ready(stdout, stderr)`` says it is running, send it
    ``signum``; its exit code."""
    out, err = where / "out.txt", where / "err.txt"
    with out.open("w") as o, err.open("w") as e:
        proc = subprocess.Popen([sys.executable, "-m", "mapr_daemon.cli.main", *args],
                                cwd=where, env=_env(), stdout=o, stderr=e)
        try:
            deadline = time.monotonic() + TIMEOUT_S
            while not ready(out.read_text(), err.read_text()):
                assert proc.poll() is None, err.read_text()
                assert time.monotonic() < deadline, err.read_text()
                time.sleep(0.2)
            proc.send_signal(signum)
            return proc.wait(timeout=TIMEOUT_S)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
    return port


def _recording(where: Path) -> Path:
    path = where / "one.c10"
    with Chapter10Writer(path, channel_id=3) as writer:
        writer.write([MonitorRecord(t_ns=1000, bus="A", format=TransferFormat.BC_RT,
                                    command=0x2822, data=(1, 2))])
    return path


DAEMON = "backend: {name: testbed}\ncatalog: {path: cat.db}\nlog_level: info\n"
BUG = ("import sys\nimport mapr_daemon.cli.commands.icd as icd\n"
       "def bug(path): raise RuntimeError('a bug')\n"
       "icd.load_icd = bug\nfrom mapr_daemon.cli.main import main\n"
       "sys.exit(main(['icd', 'check', sys.argv[1]]))\n")
"""``mapr icd check`` with a bug planted where it reads the table."""


def ok(where: Path) -> list[int]:
    (where / "mapr.yaml").write_text(DAEMON)
    daemon_ready = lambda out, err: "ready:" in err   # noqa: E731
    return [mapr(where, "icd", "check", str(ICD)),
            stopped(where, signal.SIGTERM, daemon_ready, "run", "--config", "mapr.yaml"),
            stopped(where, signal.SIGINT, daemon_ready, "run", "--config", "mapr.yaml")]


def failure(where: Path) -> list[int]:
    done = subprocess.run([sys.executable, "-c", BUG, str(ICD)], cwd=where, env=_env(),
                          capture_output=True, text=True, timeout=TIMEOUT_S)
    assert "Traceback" in done.stderr and "RuntimeError: a bug" in done.stderr
    return [done.returncode]


def usage(where: Path) -> list[int]:
    return [mapr(where, "monitor", "--rt", "40"),
            mapr(where, "fleet", "archive", "--dictionary", "d.npz", "--scheduler",
                 "bogus://x")]


def dataerr(where: Path) -> list[int]:
    return [mapr(where, "decode", str(_recording(where)), "--c10-channel", "99")]


def noinput(where: Path) -> list[int]:
    return [mapr(where, "catalog", "list", "--catalog", "nothere.sqlite")]


def unavailable(where: Path) -> list[int]:
    return [mapr(where, "fleet", "archive", "--dictionary", "d.npz", "--catalog", "f.db",
                 "--scheduler", f"tcp://127.0.0.1:{_free_port()}")]


def config(where: Path) -> list[int]:
    (where / "bad.yaml").write_text("log_level: info\nno_such_key: 1\n")
    return [mapr(where, "run", "--check", "--config", "bad.yaml")]


def interrupted(where: Path) -> list[int]:
    recording = where / "flight.c10"
    codes = [stopped(where, signal.SIGTERM, lambda out, err: recording.exists() and
                     recording.stat().st_size > 10_000,
                     "record", "--backend", "loopback", str(recording))]
    codes.append(stopped(where, signal.SIGINT, lambda out, err: out.count("\n") > 10,
                         "monitor", "--backend", "loopback"))
    return codes


CASES: dict[int, Callable[[Path], list[int]]] = {
    exitcodes.OK: ok, exitcodes.FAILURE: failure, exitcodes.USAGE: usage,
    exitcodes.DATAERR: dataerr, exitcodes.NOINPUT: noinput,
    exitcodes.UNAVAILABLE: unavailable, exitcodes.CONFIG: config,
    exitcodes.INTERRUPTED: interrupted,
}


def test_the_table_lists_every_exit_code_and_no_other() -> None:
    defined = {v for k, v in vars(exitcodes).items() if k.isupper() and isinstance(v, int)}
    assert set(table()) == defined == set(CASES)
    assert "SIGTERM" in table()[exitcodes.OK]   # the daemon's normal stop is 0, not 130


@pytest.mark.parametrize("code", sorted(table()))
def test_each_code_is_what_its_commands_end_with(code: int, tmp_path: Path) -> None:
    codes = CASES[code](tmp_path)
    assert codes and codes == [code] * len(codes), codes


def test_an_error_raised_while_ctrl_c_unwinds_still_ends_as_interrupted() -> None:
    """A backend whose clean-up fails because Ctrl-C cut it off mid-work raises one of our
    errors while the KeyboardInterrupt is handled: the user stopped the command (130), the
    error is only the echo of that."""
    from drivers.errors import BackendError
    from mapr_daemon.cli.main import _stopped_by_user

    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise BackendError("the simulator thread stopped mid-block") from None
    except BackendError as error:
        assert _stopped_by_user(error)
    assert not _stopped_by_user(BackendError("no card"))
