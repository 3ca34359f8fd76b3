"""When the daemon's main loop (decode -> reason -> catalog) falls behind the bus, the bounded
queue drops work and the daemon says so — a log line, STATUS, a catalog gap — instead of
growing without bound.

A real ``mapr run`` monitors the unpaced loopback bus (as fast as the host simulates it, with
filler traffic) through a queue of one batch. The test then stops reading the daemon's notify
socket, as a stuck service manager would: once the socket's queue is full, the main loop's
next STATUS waits in ``sendto``, while the bus reader keeps reading into the full queue. The
stall is held for a counted amount of work, not for a time: the test sees the main thread
asleep on the full socket (its ``/proc`` wait channel) and then waits until the daemon's other
threads (the reader) have used ``READER_TICKS`` clock ticks of CPU. However slowly the host
runs, the reader has then read thousands of messages past the full queue. Memory is bounded
by the queue: its peak (in STATUS) never exceeds its size.
"""

from __future__ import annotations

import re
import sqlite3
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:   # the fixture's class; pytest loads conftest itself
    from tests.daemon.conftest import Daemon

ROOT = Path(__file__).resolve().parents[2]
ICD = ROOT / "configs" / "icd" / "ema-testbed.yaml"
DROPPED = re.compile(r"the reasoner is behind the bus: (\d+) messages dropped")
PEAK = re.compile(r"queue peak (\d+)/(\d+)")
READER_TICKS = 50
"""CPU the reader must spend while the main loop is stalled (clock ticks, 10 ms each)."""
HANG_POLLS = 200_000
"""Polls of /proc before the stall is declared never reached (a hang guard, not a timing)."""


def cpu_ticks(pid: int) -> tuple[int, int]:
    """User + system clock ticks of the process's main thread, and of all its other threads."""
    main = others = 0
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            fields = (task / "stat").read_text().rsplit(")", 1)[1].split()
        except (FileNotFoundError, ProcessLookupError):
            continue   # a thread that has just ended
        ticks = int(fields[11]) + int(fields[12])
        if task.name == str(pid):
            main = ticks
        else:
            others += ticks
    return main, others


def main_thread_waits_on_peer(pid: int) -> bool:
    """True while the main thread sleeps in ``sendto`` on a full unix datagram socket."""
    try:
        return Path(f"/proc/{pid}/task/{pid}/wchan").read_text() == "unix_wait_for_peer"
    except OSError:
        return False


def hold_until_reader_worked_alone(daemon: Daemon) -> None:
    """Return once the daemon's main thread is stuck sending STATUS to the unread notify
    socket (it cannot move on until the test reads) and, since then, its other threads
    have spent ``READER_TICKS`` of CPU."""
    pid = daemon.proc.pid
    others0: int | None = None
    for _ in range(HANG_POLLS):
        assert daemon.proc.poll() is None, daemon.log
        if others0 is None:
            if main_thread_waits_on_peer(pid):
                others0 = cpu_ticks(pid)[1]
        elif cpu_ticks(pid)[1] - others0 >= READER_TICKS:
            assert main_thread_waits_on_peer(pid)
            return
        time.sleep(0.001)   # a poll interval: the outcome rests on the states, not on it
    raise AssertionError(f"the main loop never stalled on the notify socket:\n{daemon.log}")


def test_a_stalled_main_loop_drops_reports_and_stays_bounded(
        tmp_path: Path, start_daemon: Callable[..., Daemon]) -> None:
    catalog = tmp_path / "catalog.sqlite"
    daemon = start_daemon(
        f"icd: {ICD}\ntestbed: {{realtime: false, fill_bus: true}}\n"
        f"catalog: {{path: {catalog}, stats_interval_s: 0.1}}\n"
        "queue_batches: 1\nqueue_wait_s: 0\nstatus_interval_s: 0.1\n")
    daemon.wait_notify("READY=1", timeout=60)
    daemon.wait_notify("STATUS=", count=5, timeout=30)
    hold_until_reader_worked_alone(daemon)   # the notify socket is not read meanwhile
    daemon.wait_log("the reasoner is behind the bus", timeout=30)
    daemon.wait_for(lambda: any(s.startswith("STATUS=reasoner behind:")
                                for s in daemon.lines("STATUS=")), 10, "STATUS behind")
    assert daemon.terminate()[0] == 0

    dropped = sum(int(n) for n in DROPPED.findall(daemon.log))
    assert dropped >= 1, "the reader should have read on while the loop was stalled"
    line = next(x for x in daemon.log.splitlines() if "the reasoner is behind" in x)
    assert line.startswith("<4>")
    # bounded: the queue (the only buffer between the reader and the loop) never held more
    # than its one batch while thousands of messages came in
    peaks = [(int(p), int(m)) for p, m in PEAK.findall("\n".join(daemon.lines("STATUS=")))]
    assert peaks and all(p <= m == 1 for p, m in peaks)
    with sqlite3.connect(f"file:{catalog}?mode=ro", uri=True) as conn:
        reasons = [r for (r,) in conn.execute("SELECT reason FROM gaps")]
    assert reasons and all(r.startswith("reasoner behind:") for r in reasons)
    assert sum(int(r.split()[2]) for r in reasons) == dropped
    assert f"{dropped} messages dropped" in daemon.log.splitlines()[-1]
