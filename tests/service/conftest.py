"""The daemon under test: a real ``mapr run`` process, a real notify socket, real signals.

:class:`Daemon` starts ``python -m mapr_daemon.cli.main run --config FILE`` with
``NOTIFY_SOCKET`` pointing at a unix datagram socket the test owns, collects what it sends
and what it logs, and stops it with a real SIGTERM. The session-scoped ``dictionary`` is a
small fault dictionary (healthy, ESR, friction, phase-A high-side short and open; ~15 s),
decided with the dictionary's own threshold: a bus-flown BIT scores like the dictionary's
simulated ones (tests/pipeline/test_bit_on_bus.py).
"""

from __future__ import annotations

import logging
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
ICD = ROOT / "configs" / "icd" / "ema-testbed.yaml"


class Daemon:
    """One ``mapr run`` process and its notify socket."""

    def __init__(self, tmp: Path, config: Path, watchdog_usec: int | None = None) -> None:
        self.sock_path = tmp / "notify.sock"
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(str(self.sock_path))
        self.sock.settimeout(0.1)
        self.messages: list[str] = []
        self.stderr_path = tmp / "stderr.log"
        env = {**os.environ, "NOTIFY_SOCKET": str(self.sock_path), "PYTHONUNBUFFERED": "1"}
        env.pop("WATCHDOG_USEC", None)
        if watchdog_usec is not None:
            env["WATCHDOG_USEC"] = str(watchdog_usec)
        self._err = self.stderr_path.open("wb")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mapr_daemon.cli.main", "run", "--config", str(config)],
            cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=self._err)

    @property
    def log(self) -> str:
        return self.stderr_path.read_text(encoding="utf-8", errors="replace")

    def drain(self) -> None:
        while True:
            try:
                self.messages.append(self.sock.recv(4096).decode())
            except TimeoutError:
                return

    def wait_for(self, found: Callable[[], bool], timeout: float = 30.0, what: str = "") -> None:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.drain()
            if found():
                return
            if self.proc.poll() is not None:
                raise AssertionError(f"daemon exited {self.proc.returncode} waiting for "
                                     f"{what}:\n{self.log}")
        raise AssertionError(f"timed out waiting for {what}:\n{self.log}\n{self.messages}")

    def wait_notify(self, prefix: str, count: int = 1, timeout: float = 30.0) -> None:
        self.wait_for(lambda: len(self.lines(prefix)) >= count, timeout, prefix)

    def wait_log(self, text: str, timeout: float = 30.0) -> None:
        self.wait_for(lambda: text in self.log, timeout, repr(text))

    def lines(self, prefix: str) -> list[str]:
        return [line for m in self.messages for line in m.split("\n")
                if line.startswith(prefix)]

    def terminate(self) -> tuple[int, float]:
        """SIGTERM; returns (exit code, seconds it took)."""
        started = time.monotonic()
        self.proc.send_signal(signal.SIGTERM)
        code = self.proc.wait(timeout=15)
        return code, time.monotonic() - started

    def kill(self) -> None:
        """SIGKILL: no flush, no goodbye: the process dies wherever it is."""
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(timeout=15)

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()
        self._err.close()
        self.sock.close()


@pytest.fixture
def start_daemon(tmp_path: Path) -> Iterator[Callable[..., Daemon]]:
    started: list[Daemon] = []

    def start(config_text: str, watchdog_usec: int | None = None, run: str = "") -> Daemon:
        """A daemon on ``config_text``; ``run`` names a sub-directory for its socket, log and
        config, so one test can start several in turn."""
        where = tmp_path / run if run else tmp_path
        where.mkdir(exist_ok=True)
        config = where / "mapr.yaml"
        config.write_text(config_text, encoding="utf-8")
        daemon = Daemon(where, config, watchdog_usec)
        started.append(daemon)
        return daemon

    yield start
    for daemon in started:
        daemon.close()


@pytest.fixture
def mapr_log(caplog: pytest.LogCaptureFixture) -> Iterator[pytest.LogCaptureFixture]:
    """``caplog`` on the ``mapr`` logger itself: the daemon's logging setup, run by other
    tests in this process, stops it propagating to the root logger caplog listens on."""
    logger = logging.getLogger("mapr")
    logger.addHandler(caplog.handler)
    try:
        yield caplog
    finally:
        logger.removeHandler(caplog.handler)
