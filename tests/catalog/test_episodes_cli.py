"""``mapr catalog episodes`` and ``mapr catalog ack`` on real catalog files, and the schema
v3 -> v4 migration that brought episodes (a v3 file written by the previous schema code)."""

from __future__ import annotations

import json
import sqlite3
import time
from pathlib import Path

from mapr_daemon.catalog import CatalogReader, CatalogWriter, Event
from mapr_daemon.catalog.schema import LATEST, MIGRATIONS, migrate
from mapr_daemon.cli import exitcodes

from .conftest import T0
from .test_catalog_cli import mapr
from .test_episodes import ESR, bit, write


def two_episodes(path: Path) -> None:
    """EMA1: an ESR episode closed after 3 clear BITs; EMA2: an open SMPS-switch episode."""
    write(path, [bit(0, "esr", severity=0.52, part=ESR), bit(1, "esr", severity=0.66, part=ESR),
                 bit(2, None), bit(3, None), bit(4, None),
                 bit(5, "smps_ron_high", asset="EMA2", severity=0.3, part="SMPS switches"),
                 bit(6, "smps_ron_low", asset="EMA2", severity=0.35, part="SMPS switches")])


def test_episodes_lists_one_line_each_and_filters(catalog_path: Path) -> None:
    two_episodes(catalog_path)
    shown = mapr("catalog", "episodes", "--catalog", str(catalog_path))
    assert shown.returncode == 0, shown.stderr
    header, *lines = shown.stdout.splitlines()
    assert header.split()[:4] == ["ID", "ACTUATOR", "PART", "MODE"]
    assert len(lines) == 2
    assert lines[0].split()[:5] == ["2", "EMA2", "SMPS", "switches",
                                    "smps_ron_high+smps_ron_low"]
    assert "30%->35%" in lines[0] and lines[0].split()[-2:] == ["open", "-"]
    assert "52%->66%" in lines[1] and lines[1].split()[-2:] == ["closed", "-"]
    only_open = mapr("catalog", "episodes", "--open", "--catalog", str(catalog_path), "--json")
    (row,) = json.loads(only_open.stdout)
    assert (row["id"], row["asset"], row["bits"], row["state"]) == (2, "EMA2", 2, "open")
    assert row["modes"] == ["smps_ron_high", "smps_ron_low"]
    none = mapr("catalog", "episodes", "--open", "--actuator", "EMA1",
                "--catalog", str(catalog_path))
    assert none.returncode == 0 and none.stdout.startswith("no open fault episodes for EMA1")


def test_ack_stores_who_when_note_and_a_second_ack_is_refused(catalog_path: Path) -> None:
    two_episodes(catalog_path)
    before = time.time_ns()
    done = mapr("catalog", "ack", "1", "--by", "J. Smith", "--note", "capacitor replaced",
                "--catalog", str(catalog_path))
    assert done.returncode == exitcodes.OK, done.stderr
    assert done.stdout.startswith("episode 1 (EMA1, SMPS output capacitor) acknowledged by "
                                  "J. Smith at ")
    with CatalogReader(catalog_path) as reader:
        episode = reader.episode(1)
    assert episode is not None
    assert (episode.acked_by, episode.ack_note) == ("J. Smith", "capacitor replaced")
    assert episode.acked_ns is not None and before <= episode.acked_ns <= time.time_ns()
    again = mapr("catalog", "ack", "1", "--by", "K. Jones", "--catalog", str(catalog_path))
    assert again.returncode == exitcodes.USAGE
    (line,) = again.stderr.splitlines()
    assert "episode 1 was already acknowledged by J. Smith" in line
    unknown = mapr("catalog", "ack", "99", "--by", "K. Jones", "--catalog", str(catalog_path))
    assert unknown.returncode == exitcodes.USAGE
    assert unknown.stderr.splitlines() == [f"mapr catalog ack: no episode 99 in {catalog_path}"]
    with CatalogReader(catalog_path) as reader:
        assert reader.episode(1) == episode    # the first acknowledgment stands
    listed = mapr("catalog", "episodes", "--catalog", str(catalog_path))
    assert listed.stdout.splitlines()[2].endswith("closed  J. Smith")
    shown = mapr("catalog", "show", "2", "--catalog", str(catalog_path))
    assert "  episode     1 (mapr catalog episodes)" in shown.stdout.splitlines()


def test_ack_while_the_daemon_writes_keeps_both(catalog_path: Path) -> None:
    """The writer holds its connection open (as the running daemon does) and writes before
    and after the acknowledgment: neither loses the other's data."""
    with CatalogWriter(catalog_path) as writer:
        writer.open_session(backend="loopback", config_hash="e")
        writer.add_bits([bit(0, "esr", severity=0.5, part=ESR)])
        done = mapr("catalog", "ack", "1", "--by", "ops", "--catalog", str(catalog_path))
        assert done.returncode == 0, done.stderr
        writer.add_bits([bit(1, "esr", severity=0.6, part=ESR)])
    with CatalogReader(catalog_path) as reader:
        (episode,) = reader.episodes()
    assert (episode.bits, episode.sev_last, episode.acked_by) == (2, 0.6, "ops")


def test_ack_of_a_missing_catalog_is_one_line_and_exit_66(tmp_path: Path) -> None:
    missing = mapr("catalog", "ack", "1", "--by", "ops", "--catalog", str(tmp_path / "no.db"))
    assert missing.returncode == exitcodes.NOINPUT
    assert len(missing.stderr.splitlines()) == 1 and "no such file" in missing.stderr


def write_v3_file(path: Path) -> None:
    """What MAPR with schema v3 left: events with stamps, no episodes."""
    conn = sqlite3.connect(path, isolation_level=None)
    conn.execute("PRAGMA journal_mode = WAL")
    migrate(conn, str(path), steps=MIGRATIONS[:3])
    conn.execute("INSERT INTO sessions VALUES (1, ?, ?, 'loopback', 'c0ffee', '0.1.0', "
                 "'SIGTERM')", (T0, T0 + 10**12))
    for i in range(1, 12):   # eleven identical ESR events, one per BIT
        conn.execute("INSERT INTO events (id, session_id, t_ns, asset, rt, fault, severity, "
                     "confidence, evidence, bus_ns, abs_ns) VALUES (?, 1, ?, 'EMA1', 5, "
                     "'esr', ?, 0.9, ?, ?, ?)",
                     (i, T0 + i * 2 * 10**9, 0.5 + 0.01 * i, json.dumps({"part": ESR}),
                      i * 2 * 10**9, T0 + i * 2 * 10**9))
    conn.close()


def test_migration_from_v3_keeps_every_event(tmp_path: Path) -> None:
    path = tmp_path / "v3.sqlite"
    write_v3_file(path)
    with CatalogReader(path) as reader:
        assert reader.schema_version == 3
        before = reader.events(newest_first=False)
        assert reader.episodes() == [] and len(before) == 11
    refused = mapr("catalog", "ack", "1", "--by", "ops", "--catalog", str(path))
    assert refused.returncode == exitcodes.USAGE and "schema v3" in refused.stderr
    with CatalogWriter(path) as writer:
        writer.open_session(backend="loopback", config_hash="new")
        (new_id,) = writer.add_events([Event(t_ns=T0 + 30 * 10**9, asset="EMA1", fault="esr",
                                             confidence=0.9, severity=0.7,
                                             evidence={"part": ESR})])
    with CatalogReader(path) as reader:
        assert reader.schema_version == LATEST == 5
        after = reader.events(newest_first=False)
        (episode,) = reader.episodes()
    assert [e.id for e in after] == [*(e.id for e in before), new_id]
    assert [e.as_dict() for e in after[:11]] == [e.as_dict() for e in before]
    assert all(e.episode_id is None for e in after[:11])   # old events: no episode
    assert after[-1].episode_id == episode.id and episode.bits == 1
