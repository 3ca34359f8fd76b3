"""When the daemon's main loop (decode -> reason -> catalog) falls behind the bus, the bounded
queue drops work and the daemon says so — a log line, STATUS, a catalog gap — instead of
growing without bound.

A real ``mapr run`` monitors the unpaced loopback bus (as fast as the host simulates it, with
filler traffic) through a queue of one batch. The test then holds the catalog's write lock
for 4 s, as a busy or slow disk would: the main loop's next write waits on it, while the bus
reader keeps reading (thousands of messages in that time) into the full queue. Memory is
bounded by the queue: its peak (in STATUS) never exceeds its size.
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


def test_a_stalled_main_loop_drops_reports_and_stays_bounded(
        tmp_path: Path, start_daemon: Callable[..., Daemon]) -> None:
    catalog = tmp_path / "catalog.sqlite"
    daemon = start_daemon(
        f"icd: {ICD}\ntestbed: {{realtime: false, fill_bus: true}}\n"
        f"catalog: {{path: {catalog}, stats_interval_s: 0.1}}\n"
        "queue_batches: 1\nqueue_wait_s: 0\nstatus_interval_s: 0.1\n")
    daemon.wait_notify("READY=1", timeout=60)
    daemon.wait_notify("STATUS=", count=5, timeout=30)
    with sqlite3.connect(catalog, isolation_level=None) as lock:
        lock.execute("BEGIN IMMEDIATE")      # the daemon's writes now wait (busy timeout 5 s)
        time.sleep(4.0)
        lock.execute("ROLLBACK")
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
