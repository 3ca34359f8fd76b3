"""Writer and reader on real files: round trip, filters, sessions, statistics, gaps, errors."""

from __future__ import annotations

import math
import sqlite3
from collections.abc import Callable
from pathlib import Path

import pytest

from drivers.monitor import BusStatistics
from mapr_daemon.catalog import CatalogReader, CatalogWriter, Event, EventFilter
from mapr_daemon.catalog.schema import LATEST
from mapr_daemon.errors import CatalogError, MaprError

from .conftest import T0


def test_round_trip_keeps_every_field(catalog_path: Path,
                                      make_event: Callable[..., Event]) -> None:
    original = make_event(3, switch=None, evidence={"nested": {"a": [1, 2.5]}, "nan": math.nan})
    with CatalogWriter(catalog_path) as writer:
        sid = writer.open_session(backend="loopback", config_hash="abc")
        ids = writer.add_events([original, make_event(4)])
    assert ids == [1, 2]
    with CatalogReader(catalog_path) as reader:
        got = reader.event(1)
        assert reader.event(99) is None
    assert got is not None
    assert got.as_dict() == {**original.as_dict(), "id": 1, "session_id": sid,
                             "episode_id": 1, "evidence": {"nested": {"a": [1, 2.5]}, "nan": None}}


def test_ids_continue_across_batches_and_sessions(catalog_path: Path,
                                                  make_event: Callable[..., Event]) -> None:
    with CatalogWriter(catalog_path) as writer:
        writer.open_session(backend="loopback", config_hash="a")
        assert writer.add_events(make_event(i) for i in range(3)) == [1, 2, 3]
        assert writer.add_events([]) == []
    with CatalogWriter(catalog_path) as writer:
        writer.open_session(backend="loopback", config_hash="a")
        assert writer.add_events([make_event(9)]) == [4]


def test_filters(filled: Path) -> None:
    with CatalogReader(filled) as reader:
        everything = reader.events()
        assert len(everything) == 40 == reader.count()
        assert [e.t_ns for e in everything] == sorted((e.t_ns for e in everything), reverse=True)
        cases = [
            EventFilter(asset="EMA2"), EventFilter(fault="short"),
            EventFilter(min_severity=0.5), EventFilter(since_ns=T0 + 10 * 60 * 10**9),
            EventFilter(until_ns=T0 + 10 * 60 * 10**9),
            EventFilter(asset="EMA1", fault="esr", min_severity=0.2,
                        since_ns=T0 + 5 * 60 * 10**9, until_ns=T0 + 35 * 60 * 10**9),
        ]
        for flt in cases:
            expected = [e for e in everything
                        if (flt.asset is None or e.asset == flt.asset)
                        and (flt.fault is None or e.fault == flt.fault)
                        and (flt.min_severity is None or e.severity_rank >= flt.min_severity)
                        and (flt.since_ns is None or e.t_ns >= flt.since_ns)
                        and (flt.until_ns is None or e.t_ns < flt.until_ns)]
            assert reader.events(flt) == expected, flt
            assert reader.count(flt) == len(expected)
        assert reader.events(limit=5) == everything[:5]
        assert reader.events(newest_first=False) == everything[::-1]
        # a terminal fault (severity None) counts as 1.0
        assert all(e.fault == "short" for e in reader.events(EventFilter(min_severity=1.0)))


def test_user_strings_are_values_never_sql(filled: Path) -> None:
    with CatalogReader(filled) as reader:
        assert reader.events(EventFilter(asset="EMA1' OR '1'='1")) == []
        assert reader.events(EventFilter(fault="esr; DROP TABLE events; --")) == []
        assert reader.count() == 40


def test_sessions_stats_gaps(filled: Path) -> None:
    with CatalogReader(filled) as reader:
        (session,) = reader.sessions()
        assert (session.backend, session.config_hash, session.stop_reason) == \
            ("loopback", "cafe", "SIGTERM")
        stats = reader.stats()
        assert [(s.bus, s.messages, s.errors_total) for s in stats] == [
            ("A", 500, 0), ("B", 0, 0), ("A", 501, 1), ("B", 0, 0), ("A", 502, 2), ("B", 0, 0)]
        assert len(reader.stats(bus="A", limit=2)) == 2
        assert reader.stats(bus="A", limit=2)[-1].messages == 502
        (gap,) = reader.gaps()
        assert gap.reason == "backend: USB card unplugged"
        assert reader.gaps(since_ns=T0 + 7 * 10**10) == []


def test_stats_from_the_monitors_bus_statistics(catalog_path: Path) -> None:
    from drivers.monitor import open_monitor

    stats = BusStatistics()
    with open_monitor("loopback") as monitor:
        for _ in range(50):
            record = monitor.recv()   # an endless bus: a record comes, however slow the host
            assert record is not None
            stats.add(record)
    with CatalogWriter(catalog_path) as writer:
        writer.open_session(backend="loopback", config_hash="x")
        writer.add_stats(T0, T0 + 10**9, stats)
    with CatalogReader(catalog_path) as reader:
        rows = reader.stats()
    assert {r.bus: r.messages for r in rows} == dict(stats.messages)
    assert sum(r.words for r in rows) == sum(stats.words.values())


def test_killed_session_is_closed_unclean_with_a_gap(catalog_path: Path,
                                                     make_event: Callable[..., Event]) -> None:
    writer = CatalogWriter(catalog_path)
    writer.open_session(backend="serial", config_hash="a", started_ns=T0)
    writer.add_events([make_event(2)])
    writer.conn.close()  # as if killed: the session never closed
    with CatalogWriter(catalog_path) as again:
        again.open_session(backend="serial", config_hash="a", started_ns=T0 + 10 * 60 * 10**9)
        gap_id = again.record_gap(T0 + 11 * 60 * 10**9, None, "backend: card unplugged")
        again.end_gap(gap_id, T0 + 12 * 60 * 10**9)
    with CatalogReader(catalog_path) as reader:
        first, second = reader.sessions()
        assert (first.stop_reason, first.stopped_ns) == ("unclean", make_event(2).t_ns)
        assert second.stop_reason == "stopped"
        unclean, unplugged = reader.gaps()
        assert (unclean.start_ns, unclean.end_ns) == (make_event(2).t_ns, second.started_ns)
        assert unplugged.end_ns == T0 + 12 * 60 * 10**9


def test_events_need_a_session(catalog_path: Path, make_event: Callable[..., Event]) -> None:
    with CatalogWriter(catalog_path) as writer, pytest.raises(CatalogError, match="session"):
        writer.add_events([make_event(1)])


@pytest.mark.parametrize(("content", "message"), [
    (None, "no such file"),
    (b"this is not a database, just text" * 100, "corrupt or not SQLite"),
    (b"", "not a MAPR fault catalog"),
])
def test_reader_refuses_bad_files_in_one_line(tmp_path: Path, content: bytes | None,
                                              message: str) -> None:
    path = tmp_path / "catalog.sqlite"
    if content is not None:
        path.write_bytes(content)
    with pytest.raises(CatalogError, match=message) as caught:
        CatalogReader(path)
    assert isinstance(caught.value, MaprError)
    assert str(path) in str(caught.value) and "\n" not in str(caught.value)


def test_foreign_sqlite_and_newer_schema_are_refused(tmp_path: Path) -> None:
    foreign = tmp_path / "other.sqlite"
    with sqlite3.connect(foreign) as conn:
        conn.execute("CREATE TABLE t (x)")
    with pytest.raises(CatalogError, match="not a MAPR fault catalog"):
        CatalogWriter(foreign)
    with pytest.raises(CatalogError, match="not a MAPR fault catalog"):
        CatalogReader(foreign)
    newer = tmp_path / "newer.sqlite"
    CatalogWriter(newer).close()
    conn = sqlite3.connect(newer)
    conn.execute(f"PRAGMA user_version = {LATEST + 1}")
    conn.close()
    for opener in (CatalogWriter, CatalogReader):
        with pytest.raises(CatalogError, match=f"newer MAPR .schema v{LATEST + 1}"):
            opener(newer)


def test_corrupted_schema_page_is_one_line_naming_the_file(filled: Path) -> None:
    data = bytearray(filled.read_bytes())
    data[100:4096] = b"\xff" * 3996  # scribble over the schema page, keep the header
    filled.write_bytes(bytes(data))
    with pytest.raises(CatalogError, match="malformed") as caught, CatalogReader(filled) as r:
        r.events()
    assert str(filled) in str(caught.value) and "\n" not in str(caught.value)


def test_a_reasoner_event_becomes_a_catalog_event(catalog_path: Path) -> None:
    from mapr_daemon.catalog import event_from_reasoner
    from mapr_daemon.findings import Diagnosis

    decision = {"anomaly": True, "fault": "short", "severity": None, "unit": None,
                "confidence": 0.97, "parameters": {"esr_ohm": 0.06}, "soh": 0.0,
                "component": "inverter", "rul": None,
                "evidence": {"score": 9.1, "threshold": 1.0, "switch": "B_low"}}
    short = event_from_reasoner(Diagnosis.from_json(decision), t_ns=T0, asset="EMA1", rt=5)
    esr = event_from_reasoner(
        Diagnosis.from_json({**decision, "fault": "esr", "severity": 0.45, "unit": "ohm",
                             "soh": 0.6, "evidence": {"severity_fraction_of_range": 0.42}}),
        t_ns=T0 + 1, asset="EMA1", rul={"rul": 120.0, "low": 80.0, "high": 150.0})
    assert (short.switch, short.severity, short.severity_rank) == ("B_low", None, 1.0)
    assert short.evidence["component"] == "inverter" and short.rul is None
    assert (esr.severity, esr.severity_value, esr.severity_unit) == (0.42, 0.45, "ohm")
    assert (esr.rul, esr.rul_low, esr.rul_high, esr.rul_unit) == (120.0, 80.0, 150.0, "flights")
    with CatalogWriter(catalog_path) as writer:
        writer.open_session(backend="loopback", config_hash="x")
        writer.add_events([short, esr])
    with CatalogReader(catalog_path) as reader:
        assert [e.fault for e in reader.events(EventFilter(min_severity=0.5))] == ["short"]
