"""A BIT the reasoner fails on is a reasoner failure, counted and logged: not a monitoring
gap (the bus was monitored all along)."""

from __future__ import annotations

import logging
import sqlite3
from pathlib import Path

import pytest

from mapr_daemon.pipeline.pipeline import Batch, Failure
from mapr_daemon.service.config import CatalogConfig, Config
from mapr_daemon.service.reader import Item
from mapr_daemon.service.service import Service


def test_a_reasoner_failure_is_counted_and_logged_not_a_gap(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        mapr_log: pytest.LogCaptureFixture) -> None:
    path = tmp_path / "catalog.sqlite"
    service = Service(Config(catalog=CatalogConfig(path=str(path))), None)
    service.catalog.open_session(backend="testbed", config_hash="x")
    failed = Batch({}, [], [], [], [Failure(3_000_000_000, None, "ValueError: bad window",
                                            "EMA1")], True)
    monkeypatch.setattr(service.pipe, "process", lambda records, clock: failed)
    service.ready = True   # past the first decoded message
    with mapr_log.at_level(logging.ERROR, logger="mapr"):
        service._handle(Item("records"))
        service._handle(Item("records"))
    assert service.reasoner_failures == 2
    assert "reasoner failure on a BIT of EMA1 at bus time 3.000 s: ValueError: bad window " \
           "(2 reasoner failures)" in mapr_log.text
    assert "2 reasoner failures" in service._status_text()
    service.catalog.close("test")
    service.doorbell.close()
    with sqlite3.connect(path) as conn:
        assert conn.execute("SELECT count(*) FROM gaps").fetchone()[0] == 0


def test_the_daemon_names_actuators_tail_slash_actuator_as_health_does(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        mapr_log: pytest.LogCaptureFixture) -> None:
    """Event and failure log lines say ``N900/EMA1``, the name ``mapr health`` gives."""
    from mapr_daemon.catalog import Event
    from mapr_daemon.pipeline.settings import AircraftConfig
    from mapr_daemon.service.spool import Written

    config = Config(catalog=CatalogConfig(path=str(tmp_path / "catalog.sqlite")),
                    aircraft=AircraftConfig(tail="N900"))
    service = Service(config, None)
    service.catalog.open_session(backend="testbed", config_hash="x")
    failed = Batch({}, [], [], [], [Failure(3_000_000_000, None, "ValueError: bad", "EMA1")],
                   True)
    monkeypatch.setattr(service.pipe, "process", lambda records, clock: failed)
    service.ready = True
    with mapr_log.at_level(logging.INFO, logger="mapr"):
        service._handle(Item("records"))
        service._written([Written([Event(t_ns=1, asset="EMA1", fault="esr",
                                          confidence=0.9)], [7])])
    assert "reasoner failure on a BIT of N900/EMA1 at bus time 3.000 s" in mapr_log.text
    assert "event 7 written: N900/EMA1 anomaly, fault esr, confidence 0.90" in mapr_log.text
    service.catalog.close("test")
    service.doorbell.close()


def test_in_flight_rows_the_catalog_refuses_are_held_and_arrive_once(
        tmp_path: Path, mapr_log: pytest.LogCaptureFixture) -> None:
    """A catalog locked by another writer when a flight ends: its in-flight row is held (the
    trend already counts it) and written once the lock is gone, not dropped."""
    from mapr_daemon.catalog.model import InflightEstimate

    path = tmp_path / "catalog.sqlite"
    service = Service(Config(catalog=CatalogConfig(path=str(path))), None)
    service.catalog.open_session(backend="testbed", config_hash="x")
    service.catalog.conn.execute("PRAGMA busy_timeout = 20")   # a locked write fails at once
    row = InflightEstimate(tail="N1", asset="EMA1", flight=4, t_ns=1, flight_s=250.0,
                           filtered_s=50.0, parameters={"friction": {"value": 1.1}},
                           qualified_s={"friction": 50.0})
    other = sqlite3.connect(path, isolation_level=None)
    other.execute("BEGIN EXCLUSIVE")
    with mapr_log.at_level(logging.ERROR, logger="mapr"):
        service._inflight([row])
    assert service.inflight_held == [row]
    assert "1 in-flight estimates held" in mapr_log.text
    other.execute("ROLLBACK")
    other.close()
    service._retry_inflight(force=True)
    service._retry_inflight(force=True)
    assert service.inflight_held == []
    service.catalog.close("test")
    service.doorbell.close()
    with sqlite3.connect(path) as conn:
        assert conn.execute("SELECT flight FROM inflight").fetchall() == [(4,)]
