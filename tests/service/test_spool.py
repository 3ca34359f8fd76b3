"""A catalog that cannot be written for a while loses nothing and writes nothing twice.

The catalog is a real one; another connection holds SQLite's write lock (as a backup tool
or a second writer would), so the daemon's writes fail, then lets it go. The spool's clock
is the test's, so its back-off is stepped, not waited for.
"""

from __future__ import annotations

import logging
import sqlite3
from collections.abc import Iterator
from pathlib import Path

import pytest

from mapr_daemon.catalog import BitOutcome, CatalogWriter, Event
from mapr_daemon.service.spool import CatalogSpool

T0 = 1_700_000_000_000_000_000


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def writer(tmp_path: Path) -> Iterator[CatalogWriter]:
    with CatalogWriter(tmp_path / "catalog.sqlite") as catalog:
        catalog.open_session(backend="testbed", config_hash="spool")
        catalog.conn.execute("PRAGMA busy_timeout = 20")   # a locked write fails at once
        yield catalog


def bits(first: int, count: int) -> list[BitOutcome]:
    """``count`` BITs of EMA1 two seconds apart; every other one an anomaly."""
    out = []
    for i in range(first, first + count):
        t = T0 + i * 2_000_000_000
        event = Event(t, "EMA1", "friction", 0.9, rt=5) if i % 2 == 0 else None
        out.append(BitOutcome("EMA1", t, event, fault=None if event is None else "friction"))
    return out


def lock(path: str) -> sqlite3.Connection:
    other = sqlite3.connect(path, isolation_level=None)
    other.execute("BEGIN EXCLUSIVE")
    return other


def stored(path: str) -> list[int]:
    with sqlite3.connect(path) as conn:
        return [row[0] for row in conn.execute("SELECT t_ns FROM events ORDER BY id")]


def test_writes_held_while_the_catalog_is_locked_arrive_once_in_order(
        writer: CatalogWriter, mapr_log: pytest.LogCaptureFixture) -> None:
    clock = Clock()
    spool = CatalogSpool(writer.add_bits, clock=clock)
    assert [w.ids for w in spool.submit(bits(0, 2))] == [[1]]   # writable: written at once

    other = lock(writer.path)
    with mapr_log.at_level(logging.ERROR, logger="mapr"):
        assert spool.submit(bits(2, 4)) == []
    assert "BITs (2 events) held, retrying in 0.5 s" in mapr_log.text
    assert spool.due_in() == 0.5
    assert spool.submit(bits(6, 2)) == []         # queued behind, not tried before its turn
    assert spool.retry() == []
    clock.now += 0.5
    assert spool.retry() == []                    # still locked: tried, held, backs off
    assert spool.due_in() == 1.0
    assert (spool.held_bits, spool.held_events) == (6, 3)
    other.execute("ROLLBACK")
    other.close()

    clock.now += 1.0
    written = spool.retry()
    assert [len(w.ids) for w in written] == [2, 1]
    assert spool.held_bits == 0 and spool.due_in() is None
    assert spool.retry() == []
    expected = [T0 + i * 2_000_000_000 for i in range(0, 8, 2)]
    assert stored(writer.path) == expected        # every event once, in bus order
    with sqlite3.connect(writer.path) as conn:
        assert conn.execute("SELECT count(*) FROM bits").fetchone()[0] == 8


def test_beyond_its_bound_the_spool_drops_the_oldest_and_says_so(
        writer: CatalogWriter, mapr_log: pytest.LogCaptureFixture) -> None:
    clock = Clock()
    spool = CatalogSpool(writer.add_bits, bound_bits=5, clock=clock)
    other = lock(writer.path)
    with mapr_log.at_level(logging.ERROR, logger="mapr"):
        spool.submit(bits(0, 4))
        spool.submit(bits(4, 2))
    assert "catalog spool full (5 BITs): dropped the oldest batch, 4 BITs and 2 events " \
           "never written" in mapr_log.text
    assert (spool.dropped_bits, spool.dropped_events) == (4, 2)
    other.execute("ROLLBACK")
    other.close()
    clock.now += 0.5
    assert [w.ids for w in spool.retry()] == [[1]]
    assert stored(writer.path) == [T0 + 4 * 2_000_000_000]
