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

import pytest

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


def test_replaying_the_daemons_recording_gives_its_events_and_stamps(
        tmp_path: Path, start_daemon: Callable[..., Daemon], dictionary: Path) -> None:
    """The daemon records a 4 s flight (two BITs, a seeded open switch); ``mapr replay`` of
    that file writes the same events: the same bus time and absolute time to the
    nanosecond, the same fault, part and severity."""
    from mapr_daemon.catalog import CatalogReader
    from mapr_daemon.cli.main import main

    recordings = tmp_path / "recordings"
    daemon = start_daemon(flight(tmp_path, dictionary, "open=A_high", seed=3).replace(
        "duration_s: 2.0", "duration_s: 4.0") + f"record: {{path: {recordings}}}\n")
    daemon.wait_log("stream ended", timeout=120)
    assert daemon.terminate()[0] == 0
    (recording,) = recordings.iterdir()
    replayed_db = tmp_path / "replayed.sqlite"
    assert main(["replay", str(recording), "--diagnose", "--dictionary", str(dictionary),
                 "--icd", str(ICD), "--catalog", str(replayed_db), "--no-progress"]) == 0
    with CatalogReader(tmp_path / "catalog.sqlite") as catalog:
        live = catalog.events(newest_first=False)
    with CatalogReader(replayed_db) as catalog:
        replayed = catalog.events(newest_first=False)
    assert len(live) == 2 and all(e.bus_ns is not None and e.abs_ns is not None for e in live)
    assert [(e.bus_ns, e.abs_ns, e.t_ns) for e in replayed] == \
        [(e.bus_ns, e.abs_ns, e.t_ns) for e in live]
    assert [(e.asset, e.rt, e.fault, e.switch, e.evidence.get("part")) for e in replayed] == \
        [(e.asset, e.rt, e.fault, e.switch, e.evidence.get("part")) for e in live]
    for a, b in zip(replayed, live, strict=True):
        assert a.confidence == pytest.approx(b.confidence, rel=1e-3)
        assert a.evidence["score"] == pytest.approx(b.evidence["score"], rel=1e-3)
        assert a.evidence["recording"] == str(recording) and "recording" not in b.evidence
    # two BITs, requested 2 s apart by the testbed's flight control computer
    assert live[1].bus_ns - live[0].bus_ns == pytest.approx(2e9, abs=0.01e9)
    # the persistent open switch is one fault episode of two BITs, in both catalogs alike
    for db, evs in ((tmp_path / "catalog.sqlite", live), (replayed_db, replayed)):
        with CatalogReader(db) as catalog:
            (episode,) = catalog.episodes(open_only=True)
        assert (episode.asset, episode.part, episode.modes, episode.bits) == \
            ("EMA1", live[0].evidence["part"], ("open",), 2)
        assert (episode.opened_ns, episode.last_ns) == (evs[0].t_ns, evs[1].t_ns)
        assert [e.episode_id for e in evs] == [episode.id, episode.id]
