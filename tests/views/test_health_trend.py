"""`mapr catalog trend` over an actuator's BIT history: table, JSON and the plot."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.catalog.health_data import write_health_catalog
from tests.catalog.test_catalog_cli import mapr


def test_trend_lists_every_bit_by_flight_with_health(tmp_path: Path) -> None:
    path = write_health_catalog(tmp_path / "c.sqlite")
    text = mapr("catalog", "trend", "N101/EMA1", "--catalog", str(path))
    assert text.returncode == 0, text.stderr
    lines = text.stdout.splitlines()
    assert lines[0].split()[:3] == ["FLIGHT", "HOURS", "TIME"] and len(lines) == 13
    assert lines[1].split()[0] == "0" and "fewer than three BITs" in lines[1]
    assert lines[-1].split()[:6] == ["11", "27.5", "2026-05-10", "13:13:20Z", "esr", "0.34"]
    points = json.loads(mapr("catalog", "trend", "EMA1", "--tail", "N101", "--json",
                             "--catalog", str(path)).stdout)
    assert [p["flight"] for p in points] == list(range(12))
    assert points[-1]["health"]["rul_low"] == pytest.approx(10.5)


def test_trend_plot_is_drawn_in_flights_hours_and_without_data(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib", reason="--plot needs matplotlib (optional)")
    import matplotlib.image as mpimg

    path = write_health_catalog(tmp_path / "c.sqlite")
    unknown = mapr("catalog", "trend", "EMA7", "--plot", str(tmp_path / "EMA7.png"),
                   "--catalog", str(path))
    assert unknown.returncode == 2 and "no actuator EMA7" in unknown.stderr
    assert "N101/EMA1, N101/EMA2" in unknown.stderr and not (tmp_path / "EMA7.png").exists()
    for asset, extra in (("EMA1", []), ("EMA1", ["--hours"]), ("EMA2", [])):
        png = tmp_path / f"{asset}{len(extra)}.png"
        done = mapr("catalog", "trend", asset, "--plot", str(png), "--catalog", str(path),
                    *extra)
        assert done.returncode == 0, done.stderr
        pixels = mpimg.imread(png)
        assert pixels.shape[:2] == (600, 900) and float(pixels.std()) > 0.05
