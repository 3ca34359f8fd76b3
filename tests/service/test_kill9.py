"""kill -9 of the real daemon while it writes, repeated 5 times on one catalog file: afterwards the
catalog passes ``PRAGMA integrity_check`` and holds every event the daemon reported as
written (``event N written`` is logged only after the transaction committed).

Each run is a real ``mapr run`` on the loopback testbed flying the BIT with a seeded
phase-A high-side open, unpaced, so the reasoner decides within a few seconds, with bus
statistics flushed every 0.1 s so the catalog is being written to when the kill lands. The
kill comes at a different moment in each run (a fixed list, so the test is repeatable): as
the reasoner decides (the event's own transaction may be in flight), or just after the event
is reported, while the statistics are written.
"""

from __future__ import annotations

import json
import re
import sqlite3
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:   # the fixture's class; pytest loads conftest itself
    from tests.daemon.conftest import Daemon

ROOT = Path(__file__).resolve().parents[2]
ICD = ROOT / "configs" / "icd" / "ema-testbed.yaml"
WRITTEN = re.compile(r"event (\d+) written: (\S+) anomaly, fault (\S+),")
KILLS: tuple[tuple[str, float], ...] = (
    ("decided", 0.0), ("written", 0.0), ("decided", 0.004), ("written", 0.013),
    ("written", 0.07),
)
"""(log line waited for, delay before SIGKILL) per run."""


def config(tmp: Path, dictionary: Path, seed: int) -> str:
    return (f"icd: {ICD}\n"
            "testbed:\n  profile: bit\n  realtime: false\n  duration_s: 2.0\n"
            f"  seed: {seed}\n  fault: open=A_high\n"
            f"reasoner: {{dictionary: {dictionary}}}\n"
            f"catalog: {{path: {tmp / 'catalog.sqlite'}, durability: power-loss, "
            "stats_interval_s: 0.1}\n"
            "status_interval_s: 0.1\n")


def test_kill_9_while_writing_loses_no_reported_event(
        tmp_path: Path, start_daemon: Callable[..., Daemon], dictionary: Path) -> None:
    reported: dict[int, tuple[str, str]] = {}
    for run, (wait_for, delay) in enumerate(KILLS):
        daemon = start_daemon(config(tmp_path, dictionary, seed=3 + run),
                              run=f"run{run}")
        daemon.wait_log("BIT at bus time" if wait_for == "decided" else " written: ",
                        timeout=60)
        time.sleep(delay)
        daemon.kill()
        assert daemon.proc.returncode == -9
        for event_id, asset, fault in WRITTEN.findall(daemon.log):
            reported[int(event_id)] = (asset, fault)
    assert len(reported) >= sum(1 for w, _ in KILLS if w == "written")

    catalog = tmp_path / "catalog.sqlite"
    with sqlite3.connect(catalog) as conn:   # read-write: recovers the WAL as a restart would
        assert conn.execute("PRAGMA integrity_check").fetchall() == [("ok",)]
        stored = {int(i): (str(a), str(f)) for i, a, f in
                  conn.execute("SELECT id, asset, fault FROM events")}
        sessions = conn.execute("SELECT stop_reason FROM sessions ORDER BY id").fetchall()
        gaps = conn.execute("SELECT COUNT(*) FROM gaps WHERE reason LIKE 'daemon not running%'"
                            ).fetchone()[0]
    for event_id, (asset, fault) in reported.items():
        assert stored.get(event_id) == (asset, fault), f"reported event {event_id} lost"
    assert set(stored.values()) == {("EMA1", "open")}
    # every killed session but the last was closed as unclean by the next start
    assert len(sessions) == len(KILLS)
    assert [r for (r,) in sessions[:-1]] == ["unclean"] * (len(KILLS) - 1)
    assert gaps == len(KILLS) - 1
    # and the catalog CLI reads what survived
    listed = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "catalog",
                             "--catalog", str(catalog), "list", "--json", "--limit", "0"],
                            cwd=ROOT, capture_output=True, text=True, timeout=60, check=False)
    assert listed.returncode == 0, listed.stderr
    assert set(reported) <= {int(e["id"]) for e in json.loads(listed.stdout)}
