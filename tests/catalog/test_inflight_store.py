"""Per-flight in-flight estimates in the catalog: stored, read back, replaced on a rerun, and
absent (not an error) in a catalog from before schema v9."""

from __future__ import annotations

import sqlite3
from pathlib import Path

from mapr_daemon.catalog import CatalogReader, CatalogWriter, InflightEstimate
from mapr_daemon.catalog.schema import LATEST, MIGRATIONS, migrate

from .conftest import T0


def _estimate(flight: int, friction: float) -> InflightEstimate:
    return InflightEstimate(
        tail="N101", asset="EMA1", flight=flight, t_ns=T0 + flight * 10**12, flight_s=255.0,
        filtered_s=48.0,
        parameters={"friction": {"value": friction, "sd": 0.03, "change": friction - 1.0,
                                 "unit": "x baseline"},
                    "bus0": {"value": 0.01, "sd": float("inf"), "change": 0.0,
                             "unit": "V/A (proxy)"}},
        qualified_s={"friction": 20.0, "loop": 6.0, "phase_a": 0.0, "bus": 22.0})


def test_estimates_are_stored_read_back_and_a_rerun_replaces_its_flight(tmp_path: Path) -> None:
    path = tmp_path / "c.sqlite"
    with CatalogWriter(path) as writer:
        writer.open_session(backend="replay", config_hash="x")
        writer.add_inflight([_estimate(1, 1.02), _estimate(2, 1.30)])
        writer.add_inflight([_estimate(2, 1.25)])  # flight 2 replayed again
    with CatalogReader(path) as reader:
        got = reader.inflight(asset="EMA1")
        assert [(e.flight, e.parameters["friction"]["value"]) for e in got] == [(1, 1.02),
                                                                             (2, 1.25)]
        first = got[0]
        assert first.parameters["friction"]["unit"] == "x baseline"
        assert first.parameters["bus0"]["sd"] is None  # a non-finite sd is stored as unknown
        assert dict(first.qualified_s) == {"friction": 20.0, "loop": 6.0, "phase_a": 0.0,
                                           "bus": 22.0}
        assert (first.flight_s, first.filtered_s) == (255.0, 48.0)
        assert reader.inflight(asset="EMA2") == []


def test_a_v8_catalog_has_no_estimates_until_migrated(tmp_path: Path) -> None:
    path = tmp_path / "v8.sqlite"
    conn = sqlite3.connect(path, isolation_level=None)
    migrate(conn, str(path), steps=MIGRATIONS[:8])
    conn.close()
    with CatalogReader(path) as reader:
        assert reader.schema_version == 8
        assert reader.inflight() == []
    with CatalogWriter(path) as writer:
        writer.open_session(backend="replay", config_hash="x")
        writer.add_inflight([_estimate(3, 1.1)])
    with CatalogReader(path) as reader:
        assert reader.schema_version == LATEST >= 9
        assert [e.flight for e in reader.inflight()] == [3]
