"""Each flight's in-flight estimate beside the BIT readings: `mapr health` (text and JSON),
`catalog export` (bits with their flight's estimate, and the estimates alone) and the report,
all written by the one formatter (views/figures.py)."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

from mapr_daemon.catalog import CatalogReader, CatalogWriter
from mapr_daemon.catalog.model import InflightEstimate
from mapr_daemon.reasoner.inflight.baseline import Baseline
from mapr_daemon.views import html_report
from tests.catalog.conftest import HOUR, T0
from tests.catalog.health_data import write_health_catalog
from tests.catalog.test_catalog_cli import mapr


def _catalog(tmp_path: Path) -> Path:
    """The health catalog (N101: EMA1 wearing, EMA2 healthy, flights 0-11) with EMA1's
    in-flight rows: flights 1-3 commission friction at 1.1x the data sheet, flight 11 reads
    1.65x (a change of +0.5 over the baseline; its sd 0.82: four flights cannot tell that
    jump from the unit's own flight-to-flight scatter, reasoner/inflight/scatter.py)."""
    path = write_health_catalog(tmp_path / "c.sqlite")
    base = Baseline()
    rows = []
    for flight, value in ((1, 1.08), (2, 1.1), (3, 1.12), (11, 1.65)):
        params = base.rebase({"friction": {"value": value, "sd": 0.022, "unit": "x baseline"},
                              "loop_r": {"value": 0.7, "sd": 0.05, "unit": "ohm"}})
        rows.append(InflightEstimate("N101", "EMA1", flight, T0 + flight * 3 * HOUR + HOUR,
                                     255.0, 52.0, params, {"friction": 40.0}))
    with CatalogWriter(path) as writer:
        writer.open_session(backend="loopback", config_hash="cafe")
        writer.add_inflight(rows)
    return path


def test_health_shows_the_last_flight_estimate_in_text_and_json(tmp_path: Path) -> None:
    path = _catalog(tmp_path)
    text = mapr("health", "--catalog", str(path))
    assert text.returncode == 0, text.stderr
    assert "N101/EMA1 flight 11: in-flight estimate from 52 s of 255 s" in text.stdout
    assert "friction +0.50 +/- 0.82 x baseline" in text.stdout
    rows = {r["asset"]: r for r in json.loads(
        mapr("health", "--json", "--catalog", str(path)).stdout)}
    friction = rows["EMA1"]["inflight"]["parameters"]["friction"]
    assert rows["EMA1"]["inflight"]["flight"] == 11
    assert friction["change"] == 0.5 and friction["baseline"] == 1.1
    assert friction["text"] == "friction +0.50 +/- 0.82 x baseline"
    assert rows["EMA2"]["inflight"] is None


def test_the_export_carries_each_bit_flight_estimate_and_the_estimates_alone(
        tmp_path: Path) -> None:
    path = _catalog(tmp_path)
    done = mapr("catalog", "export", "--what", "bits", "--format", "csv", "--catalog",
                str(path))
    assert done.returncode == 0, done.stderr
    bits = list(csv.DictReader(io.StringIO(done.stdout)))
    at11 = [b for b in bits if b["asset"] == "EMA1" and b["flight"] == "11"]
    assert at11 and at11[0]["inflight_friction_change"] == "0.5"
    assert at11[0]["inflight_friction_text"] == "friction +0.50 +/- 0.82 x baseline"
    assert all(b["inflight_friction_change"] == "" for b in bits if b["asset"] == "EMA2")
    alone = mapr("catalog", "export", "--what", "inflight", "--format", "jsonl",
                 "--catalog", str(path))
    lines = [json.loads(line) for line in alone.stdout.splitlines()]
    assert [r["flight"] for r in lines] == [1, 2, 3, 11]
    assert lines[0]["parameters"]["friction"]["baseline"] == "pending 1/3"


def test_the_report_lists_the_actuator_in_flight_estimates(tmp_path: Path) -> None:
    path = _catalog(tmp_path)
    with CatalogReader(path) as reader:
        page = html_report.build(reader, T0)
    ema1 = page[page.index('<section id="N101/EMA1">'):]
    ema1 = ema1[:ema1.index("</section>")]
    assert "In-flight estimates" in ema1 and "+0.50 +/- 0.82 x baseline" in ema1
    assert "baseline pending 1/3" in ema1
