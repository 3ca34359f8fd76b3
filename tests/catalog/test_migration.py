"""Schema versions: a file written by the v1 program opens, and is migrated, with this one."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from mapr_daemon.catalog import CatalogReader, CatalogWriter, Event, EventFilter
from mapr_daemon.catalog.schema import LATEST, MIGRATIONS, migrate

from .conftest import T0


def write_v1_file(path: Path) -> None:
    """What MAPR with schema v1 left on disk: WAL, v1 tables, a session, two events."""
    conn = sqlite3.connect(path, isolation_level=None)
    conn.execute("PRAGMA journal_mode = WAL")
    migrate(conn, str(path), steps=MIGRATIONS[:1])
    conn.execute("INSERT INTO sessions VALUES (1, ?, ?, 'serial', 'c0ffee', '0.0.1')",
                 (T0, T0 + 10**12))
    for i, fault in ((1, "esr"), (2, "friction")):
        conn.execute("INSERT INTO events (id, session_id, t_ns, asset, fault, severity, "
                     "confidence, soh) VALUES (?, 1, ?, 'EMA1', ?, 0.3, 0.8, 0.9)",
                     (i, T0 + i * 10**9, fault))
    conn.close()


def test_v1_file_is_read_then_migrated_by_the_current_program(tmp_path: Path) -> None:
    assert LATEST >= 7   # v5: BIT history and flights; v6: per-RT/SA statistics
    path = tmp_path / "old.sqlite"
    write_v1_file(path)
    with CatalogReader(path) as reader:  # the CLI reads an old file as it is
        assert reader.schema_version == 1
        assert [e.fault for e in reader.events()] == ["friction", "esr"]
        assert reader.sessions()[0].stop_reason is None
    with CatalogWriter(path) as writer:
        assert writer.conn.execute("PRAGMA user_version").fetchone()[0] == LATEST
        writer.open_session(backend="loopback", config_hash="new")
    with CatalogReader(path) as reader:
        assert reader.schema_version == LATEST
        assert [e.id for e in reader.events(EventFilter(asset="EMA1"))] == [2, 1]
        old, new = reader.sessions()
        assert (old.backend, old.stopped_ns, old.stop_reason) == ("serial", T0 + 10**12, None)
        assert new.stop_reason == "stopped"
        plan = " ".join(str(r) for r in reader._conn.execute(
            "EXPLAIN QUERY PLAN SELECT id FROM events WHERE asset = ? ORDER BY t_ns DESC",
            ("EMA1",)))
        assert "events_asset_t" in plan


def test_migrated_file_has_the_schema_of_a_new_one(tmp_path: Path) -> None:
    write_v1_file(tmp_path / "old.sqlite")
    CatalogWriter(tmp_path / "old.sqlite").close()
    CatalogWriter(tmp_path / "new.sqlite").close()

    def schema(path: Path) -> list[tuple[str, str]]:
        with sqlite3.connect(path) as conn:
            return conn.execute("SELECT name, sql FROM sqlite_schema ORDER BY name").fetchall()

    assert schema(tmp_path / "old.sqlite") == schema(tmp_path / "new.sqlite")


def test_a_failing_step_leaves_the_previous_version(tmp_path: Path) -> None:
    path = tmp_path / "c.sqlite"
    CatalogWriter(path).close()
    broken = (*MIGRATIONS, ("CREATE INDEX extra ON events(soh)", "CREATE TABLE oops ("))
    conn = sqlite3.connect(path, isolation_level=None)
    with pytest.raises(sqlite3.OperationalError):
        migrate(conn, str(path), steps=broken)
    assert conn.execute("PRAGMA user_version").fetchone()[0] == LATEST
    assert conn.execute("SELECT count(*) FROM sqlite_schema WHERE name = 'extra'"
                        ).fetchone()[0] == 0
    conn.close()


def write_v2_file(path: Path) -> None:
    """What MAPR with schema v2 left: an event without bus or absolute time."""
    conn = sqlite3.connect(path, isolation_level=None)
    conn.execute("PRAGMA journal_mode = WAL")
    migrate(conn, str(path), steps=MIGRATIONS[:2])
    conn.execute("INSERT INTO sessions VALUES (1, ?, ?, 'loopback', 'c0ffee', '0.1.0', "
                 "'SIGTERM')", (T0, T0 + 10**12))
    conn.execute("INSERT INTO events (id, session_id, t_ns, asset, rt, fault, severity, "
                 "confidence) VALUES (1, 1, ?, 'EMA1', 5, 'esr', 0.6, 0.9)", (T0 + 10**9,))
    conn.close()


def test_v2_file_gains_the_event_stamps_and_keeps_its_events(tmp_path: Path) -> None:
    path = tmp_path / "v2.sqlite"
    write_v2_file(path)
    with CatalogReader(path) as reader:   # read as it is, the stamps unknown
        assert reader.schema_version == 2
        (old,) = reader.events()
        assert (old.fault, old.t_ns, old.bus_ns, old.abs_ns) == ("esr", T0 + 10**9, None, None)
    with CatalogWriter(path) as writer:   # the writer migrates, then stores the new fields
        writer.open_session(backend="chapter10", config_hash="new")
        writer.add_events([Event(t_ns=T0 + 5 * 10**9, asset="EMA1", fault="friction",
                                 confidence=0.7, rt=5, bus_ns=2_000_012_300,
                                 abs_ns=T0 + 5 * 10**9)])
    with CatalogReader(path) as reader:
        assert reader.schema_version == LATEST
        new, old = reader.events()
        assert (old.fault, old.bus_ns, old.abs_ns) == ("esr", None, None)
        assert (new.fault, new.bus_ns, new.abs_ns) == ("friction", 2_000_012_300,
                                                       T0 + 5 * 10**9)
        assert reader.event(new.id or 0) == new


def test_a_v7_files_bit_history_is_read_as_it_is_then_migrated(tmp_path: Path) -> None:
    """A v7 catalog (BIT history without flight conditions), read by the CLI without
    migrating it: its BITs come back with empty conditions; the daemon then migrates it and
    the same BITs keep {} while new ones carry theirs."""
    path = tmp_path / "v7.sqlite"
    conn = sqlite3.connect(path, isolation_level=None)
    migrate(conn, str(path), steps=MIGRATIONS[:7])
    conn.execute("INSERT INTO bits (tail, asset, t_ns, flight, wear, modes) VALUES "
                 "('N101', 'EMA1', ?, 3, '{\"esr\": 0.2}', '{}')", (T0,))
    conn.close()
    with CatalogReader(path) as reader:
        assert reader.schema_version == 7
        (b,) = reader.bits()
        assert (b.flight, dict(b.wear), dict(b.conditions)) == (3, {"esr": 0.2}, {})
    CatalogWriter(path).close()
    with CatalogReader(path) as reader:
        assert reader.schema_version == LATEST >= 8
        assert [dict(b.conditions) for b in reader.bits()] == [{}]
