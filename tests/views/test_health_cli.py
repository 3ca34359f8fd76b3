"""`mapr health`: one line per actuator a maintainer reads, and JSON for programs."""

from __future__ import annotations

import json
from pathlib import Path

from mapr_daemon.catalog import CatalogWriter
from tests.catalog.health_data import write_health_catalog
from tests.catalog.test_catalog_cli import mapr


def test_health_lines_name_soh_mode_rul_episodes_and_service(tmp_path: Path) -> None:
    path = write_health_catalog(tmp_path / "c.sqlite")
    done = mapr("health", "--catalog", str(path))
    assert done.returncode == 0, done.stderr
    header, ema1, ema2 = done.stdout.splitlines()
    assert header.split()[:3] == ["ACTUATOR", "SOH", "MODE"]
    # EMA1 after flight 11: SoH 1 - 0.66, ESR leading, RUL 15 flights (10.5-21), 37.5 h
    assert ema1.split()[:3] == ["N101/EMA1", "0.34", "esr"]
    assert "15 (10-21) flights" in ema1 and "38 (26-52) h" in ema1
    assert "3 open (dc-link capacitor)" not in ema1 and "1 open (dc-link capacitor)" in ema1
    assert "2026-05-10 13:13:20Z" in ema1 and "2026-05-09 04:13:20Z" in ema1
    # EMA2: nothing wears, so no RUL figure but the note's words
    assert ema2.split()[:3] == ["N101/EMA2", "1.00", "-"]
    assert "no part wears measurably" in ema2 and "none" in ema2


def test_health_json_carries_interval_and_episodes(tmp_path: Path) -> None:
    path = write_health_catalog(tmp_path / "c.sqlite")
    done = mapr("health", "--json", "--catalog", str(path))
    rows = {r["asset"]: r for r in json.loads(done.stdout)}
    ema1 = rows["EMA1"]
    assert ema1["tail"] == "N101" and ema1["soh"] == 0.34 and ema1["mode"] == "esr"
    assert ema1["rul_flights"] == {"median": 15.0, "low": 10.5, "high": 21.0}
    assert ema1["rul_hours"]["median"] == 37.5 and ema1["interval"] == 0.9
    assert [e["part"] for e in ema1["open_episodes"]] == ["dc-link capacitor"]
    assert ema1["last_flight"] == 11 and ema1["first_flight"] == 0 and ema1["bits"] == 12
    assert rows["EMA2"]["rul_flights"]["median"] is None
    assert rows["EMA2"]["note"].startswith("no part wears")


def test_health_of_an_empty_catalog_and_a_missing_one(tmp_path: Path) -> None:
    path = tmp_path / "empty.sqlite"
    with CatalogWriter(path) as writer:
        writer.open_session(backend="loopback", config_hash="x")
    done = mapr("health", "--catalog", str(path))
    assert done.returncode == 0 and "no BIT history" in done.stdout
    missing = mapr("health", "--catalog", str(tmp_path / "nope.sqlite"))
    assert missing.returncode == 66 and "nope.sqlite" in missing.stderr
    assert len(missing.stderr.strip().splitlines()) == 1


def test_a_fleet_asset_carrying_its_tail_is_not_named_twice() -> None:
    from mapr_daemon.catalog.actuators import display_name

    assert display_name("N101", "EMA1") == "N101/EMA1"
    assert display_name("N101", "N101/EMA1") == "N101/EMA1"
    assert display_name("", "N7/EMA2") == "N7/EMA2"
