"""End to end on the loopback testbed: the simulated aircraft flies its built-in test over
the 1553 bus, the daemon cuts the BIT out of the traffic, the reasoner decides, the catalog
keeps the event, and ``mapr catalog list`` shows it."""

from __future__ import annotations

import json
import os
import sqlite3
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:   # the fixture's class; pytest loads conftest itself
    from tests.daemon.conftest import Daemon

ROOT = Path(__file__).resolve().parents[2]
ICD = ROOT / "configs" / "icd" / "ema-testbed.yaml"


def flight(tmp: Path, dictionary: Path, fault: str | None,
           seed: int) -> str:
    return (f"icd: {ICD}\n"
            "testbed:\n  profile: bit\n  condition: cruise\n  realtime: false\n"
            f"  duration_s: 2.0\n  seed: {seed}\n  fault: {json.dumps(fault)}\n"
            f"reasoner: {{dictionary: {dictionary}}}\n"
            "assets: [{name: EMA1, rt: 5}]\n"
            f"catalog: {{path: {tmp / 'catalog.sqlite'}, stats_interval_s: 0.5}}\n")


def events(path: Path) -> list[tuple[object, ...]]:
    with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as conn:
        return conn.execute("SELECT asset, rt, fault, switch FROM events").fetchall()


def test_seeded_fault_reaches_the_catalog_and_the_cli(
        tmp_path: Path, start_daemon: Callable[..., Daemon], dictionary: Path) -> None:
    daemon = start_daemon(flight(tmp_path, dictionary, "open=A_high", seed=3))
    daemon.wait_notify("READY=1", timeout=60)
    daemon.wait_log("event 1 written", timeout=60)
    daemon.wait_for(lambda: any("1 events" in s for s in daemon.lines("STATUS=")), 10,
                    "STATUS with the event")
    assert daemon.terminate()[0] == 0
    catalog = tmp_path / "catalog.sqlite"
    assert events(catalog) == [("EMA1", 5, "open", "A_high")]
    listed = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "catalog", "list"],
                            cwd=ROOT, capture_output=True, text=True, timeout=60,
                            env={**os.environ, "MAPR_CATALOG": str(catalog)})
    assert listed.returncode == 0, listed.stderr
    assert "EMA1" in listed.stdout and "open/A_high" in listed.stdout


def test_nominal_flight_writes_no_event(
        tmp_path: Path, start_daemon: Callable[..., Daemon], dictionary: Path) -> None:
    daemon = start_daemon(flight(tmp_path, dictionary, None, seed=1))
    daemon.wait_log(": nominal (score", timeout=60)
    daemon.wait_log("stream ended", timeout=60)
    assert daemon.terminate()[0] == 0
    assert events(tmp_path / "catalog.sqlite") == []
