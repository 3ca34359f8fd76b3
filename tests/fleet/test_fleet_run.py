"""A fleet run into one catalog: idempotent, resumable, a killed worker loses nothing, a bad
recording is reported and the rest stored, each tail's flights stored in flight order."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from mapr_daemon.catalog import CatalogWriter
from mapr_daemon.cli import exitcodes
from mapr_daemon.fleet.archive import discover
from mapr_daemon.fleet.config import FleetConfig
from mapr_daemon.fleet.runner import FleetRun, RunSummary
from mapr_daemon.fleet.task import TaskResult
from mapr_daemon.pipeline.settings import ReasonerConfig
from mapr_daemon.service.config import Config

ROOT = Path(__file__).resolve().parents[2]


def configs(dictionary: Path) -> FleetConfig:
    return FleetConfig(Config(reasoner=ReasonerConfig(dictionary=str(dictionary))))


def run_fleet(client: Any, archive: Path, catalog: Path, dictionary: Path,
              on_stored: Any = None) -> RunSummary:
    recordings, _ = discover([archive])
    with CatalogWriter(catalog) as writer:
        writer.open_session(backend="fleet", config_hash="test")
        return FleetRun(client, writer, configs(dictionary), on_stored).run(recordings)


def contents(catalog: Path) -> tuple[list[tuple[Any, ...]], list[tuple[Any, ...]], int]:
    """(recordings in insertion order, events, BITs counted by the recordings rows)."""
    with sqlite3.connect(f"file:{catalog}?mode=ro", uri=True) as conn:
        rows = conn.execute("SELECT tail, flight, status, bits, events FROM recordings "
                            "ORDER BY id").fetchall()
        events = conn.execute("SELECT asset, bus_ns, abs_ns, fault FROM events ORDER BY id"
                              ).fetchall()
    return rows, events, sum(r[3] for r in rows)


def test_same_archive_twice_stores_each_recording_once(
        dask_client: Any, fleet_archive: Path, fleet_dictionary: Path, tmp_path: Path) -> None:
    catalog = tmp_path / "fleet.db"
    first = run_fleet(dask_client, fleet_archive, catalog, fleet_dictionary)
    assert (first.stored, first.skipped, first.failed) == (4, 0, [])
    rows, events, bits = contents(catalog)
    # every flight has its BIT; flights of a tail stored in flight order
    for tail in ("N101", "N102"):
        assert [r[1] for r in rows if r[0] == tail] == [1, 2]
    assert all(r[2] == "done" and r[3] == 1 for r in rows) and bits == 4
    assert {e[0] for e in events} <= {"N101/EMA1", "N102/EMA1"}
    assert all(e[2] is not None for e in events)   # absolute time from the time packets
    second = run_fleet(dask_client, fleet_archive, catalog, fleet_dictionary)
    assert (second.stored, second.skipped) == (0, 4)
    assert contents(catalog) == (rows, events, bits)


def test_a_worker_killed_mid_run_loses_nothing(
        dask_client: Any, fleet_archive: Path, fleet_dictionary: Path, tmp_path: Path) -> None:
    """After the first recording is stored, SIGKILL a worker that is busy with another; the
    scheduler reruns its task elsewhere and the catalog ends complete, without duplicates,
    and equal to an undisturbed run's."""
    pids = dask_client.run(os.getpid)
    killed: list[str] = []

    def kill_busy_worker(result: TaskResult) -> None:
        if killed:
            return
        busy = [w for w, keys in dask_client.processing().items() if keys]
        victim = (busy or sorted(pids))[0]
        killed.append(victim)
        os.kill(pids[victim], signal.SIGKILL)

    catalog = tmp_path / "killed.db"
    summary = run_fleet(dask_client, fleet_archive, catalog, fleet_dictionary,
                        kill_busy_worker)
    assert killed and summary.stored == 4 and summary.failed == []
    reference = tmp_path / "reference.db"
    run_fleet(dask_client, fleet_archive, reference, fleet_dictionary)
    rows, events, bits = contents(catalog)
    assert len(rows) == 4 and bits == 4
    assert len(set(events)) == len(events)
    assert contents(catalog)[1] == contents(reference)[1]
    dask_client.wait_for_workers(2, timeout=60)


def test_a_bad_recording_is_reported_and_the_rest_stored(
        dask_client: Any, fleet_archive: Path, fleet_dictionary: Path, tmp_path: Path) -> None:
    (fleet_archive / "N101" / "flight-0003.ch10").write_bytes(b"not chapter 10 at all" * 50)
    catalog = tmp_path / "fleet.db"
    summary = run_fleet(dask_client, fleet_archive, catalog, fleet_dictionary)
    assert summary.stored == 4
    (failed,) = summary.failed
    assert failed.recording.flight == 3 and failed.error and "Chapter 10" in failed.error
    rows, _, _ = contents(catalog)
    assert ("N101", 3, "failed", 0, 0) in rows and len(rows) == 5
    again = run_fleet(dask_client, fleet_archive, catalog, fleet_dictionary)
    assert (again.stored, again.skipped, len(again.failed)) == (0, 4, 1)   # retried, once
    assert len(contents(catalog)[0]) == 5


def _fleet(archive: Path, catalog: Path, dictionary: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "mapr_daemon.cli.main", "fleet", str(archive), "--dictionary",
         str(dictionary), "--catalog", str(catalog), "--workers", "1", "--no-progress"],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)})


def _stored(catalog: Path) -> int:
    try:
        with sqlite3.connect(f"file:{catalog}?mode=ro", uri=True) as conn:
            return int(conn.execute("SELECT count(*) FROM recordings").fetchone()[0])
    except sqlite3.Error:
        return 0


def test_the_client_killed_mid_run_resumes_with_only_what_is_missing(
        fleet_archive: Path, fleet_dictionary: Path, tmp_path: Path) -> None:
    catalog = tmp_path / "fleet.db"
    first = _fleet(fleet_archive, catalog, fleet_dictionary)
    while _stored(catalog) == 0 and first.poll() is None:
        time.sleep(0.2)
    first.send_signal(signal.SIGKILL)   # the client and its cluster die wherever they are
    first.communicate()
    # counted as the next run will see it: a read-write connection recovers the WAL of a
    # writer killed mid-commit, where a read-only one may read the index it left stale
    with sqlite3.connect(catalog) as conn:
        done_before = int(conn.execute("SELECT count(*) FROM recordings").fetchone()[0])
    assert done_before >= 1
    second = _fleet(fleet_archive, catalog, fleet_dictionary)
    out, err = second.communicate(timeout=300)
    assert second.returncode == exitcodes.OK, err
    assert f"{4 - done_before} stored, {done_before} already in the catalog" in out
    rows, events, bits = contents(catalog)
    assert sorted((r[0], r[1]) for r in rows) == [("N101", 1), ("N101", 2), ("N102", 1),
                                                  ("N102", 2)]
    assert bits == 4 and len(set(events)) == len(events)


def test_damaged_packets_are_named_with_their_file_and_offset(
        dask_client: Any, fleet_archive: Path, fleet_dictionary: Path, tmp_path: Path) -> None:
    """A recording with a few damaged packets is stored from the rest of its packets, and the
    run names each packet skipped (file and offset), as ``mapr replay`` does."""
    path = fleet_archive / "N102" / "flight-0002.ch10"
    data = bytearray(path.read_bytes())
    for at in range(len(data) // 3, len(data) // 3 + 4000, 997):
        data[at] ^= 0xFF
    path.write_bytes(bytes(data))
    summary = run_fleet(dask_client, fleet_archive, tmp_path / "fleet.db", fleet_dictionary)
    assert summary.stored == 4 and not summary.failed
    assert summary.damaged and len(summary.damaged) == summary.damaged_packets
    assert all(line.startswith(f"{path}: offset ") for line in summary.damaged), summary.damaged
