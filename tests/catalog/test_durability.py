"""kill -9 of a real writer process, again and again: nothing reported as written is lost.

The writer (``writer_proc.py``) prints the ids of each batch only after its COMMIT returned.
The test reads those lines, kills the process with SIGKILL at a random moment (often in the
middle of the next transaction), and checks the file: ``PRAGMA integrity_check`` is ``ok``
and every reported id is there. The next round reopens the same file (hot WAL recovery) and
closes the killed session as ``unclean``. Power loss cannot be cut here; the writer runs
with ``synchronous=FULL``, which fsyncs the WAL at each commit (see docs/catalog.md).
"""

from __future__ import annotations

import os
import random
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

from mapr_daemon.catalog import CatalogReader

ROOT = Path(__file__).resolve().parents[2]
WRITER = Path(__file__).with_name("writer_proc.py")
ROUNDS = 20


def run_and_kill(path: Path, seed: int, rng: random.Random) -> set[int]:
    """Start the writer, let it report a random number of batches, SIGKILL it; the ids it
    reported (complete lines only)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, str(WRITER), str(path), str(seed)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    assert proc.stdout is not None and proc.stderr is not None
    reported: set[int] = set()
    try:
        for _ in range(rng.randint(1, 25)):
            line = proc.stdout.readline()
            assert line.endswith(b"\n"), proc.stderr.read().decode()
            reported.update(int(x) for x in line.split())
        time.sleep(rng.random() * 0.02)  # land inside a later transaction, or between two
    finally:
        proc.send_signal(signal.SIGKILL)
        rest, err = proc.communicate(timeout=30)
    assert proc.returncode == -signal.SIGKILL, err.decode()
    for line in rest.split(b"\n")[:-1]:  # lines printed before the kill were committed too
        reported.update(int(x) for x in line.split())
    return reported


def test_kill_9_loses_nothing_reported_and_leaves_a_sound_file(tmp_path: Path) -> None:
    path = tmp_path / "catalog.sqlite"
    rng = random.Random(1553)
    reported: set[int] = set()
    for seed in range(ROUNDS):
        reported |= run_and_kill(path, seed, rng)
        assert Path(f"{path}-wal").exists()  # killed: the WAL was left behind, not merged
        conn = sqlite3.connect(path)  # a plain connection, as any tool would open it
        try:
            assert conn.execute("PRAGMA integrity_check").fetchall() == [("ok",)]
            stored = {row[0] for row in conn.execute("SELECT id FROM events")}
        finally:
            conn.close()
        missing = reported - stored
        assert not missing, f"round {seed}: {len(missing)} reported ids lost"
    assert len(reported) > ROUNDS
    with CatalogReader(path) as reader:  # the CLI's read-only view of the killed file
        sessions = reader.sessions()
        assert len(sessions) == ROUNDS
        assert [s.stop_reason for s in sessions[:-1]] == ["unclean"] * (ROUNDS - 1)
        assert sessions[-1].stopped_ns is None  # the last kill: nobody has reopened it yet
        assert len(reader.gaps()) == ROUNDS - 1
        assert reader.count() >= len(reported)


def test_writer_uses_full_synchronous_in_wal(tmp_path: Path) -> None:
    from mapr_daemon.catalog import CatalogWriter

    with CatalogWriter(tmp_path / "c.sqlite") as writer:
        assert writer.conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
        assert writer.conn.execute("PRAGMA synchronous").fetchone()[0] == 2  # FULL
    with CatalogWriter(tmp_path / "c.sqlite", durability="crash") as writer:
        assert writer.conn.execute("PRAGMA synchronous").fetchone()[0] == 1  # NORMAL
