"""`mapr catalog export --what bits|episodes|events`: JSON lines whole, CSV flat."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

from tests.catalog.health_data import write_health_catalog
from tests.catalog.test_catalog_cli import mapr


def _csv(text: str) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(text)))


def test_bits_csv_is_flat_with_wear_and_mode_columns(tmp_path: Path) -> None:
    path = write_health_catalog(tmp_path / "c.sqlite")
    done = mapr("catalog", "export", "--what", "bits", "--format", "csv",
                "--catalog", str(path))
    assert done.returncode == 0, done.stderr
    rows = _csv(done.stdout)
    assert len(rows) == 24
    for row in rows:  # no JSON in any cell
        assert not any(cell.startswith(("{", "[")) for cell in row.values())
    last = [r for r in rows if r["asset"] == "EMA1"][-1]
    assert last["flight"] == "11" and last["fault"] == "esr" and last["soh"] == "0.34"
    assert float(last["wear_esr"]) == 0.66 and float(last["mode_esr_rul"]) == 15.0
    assert last["mode_esr_evidenced"] == "true" and last["rul_hours_high"] == "52.5"
    healthy = [r for r in rows if r["asset"] == "EMA2"][-1]
    assert healthy["wear_friction"] == "0.02" and healthy["wear_capacitance"] == ""
    assert healthy["rul"] == "" and healthy["note"].startswith("no part wears")


def test_bits_jsonl_keeps_records_whole_and_filters(tmp_path: Path) -> None:
    path = write_health_catalog(tmp_path / "c.sqlite")
    out = tmp_path / "bits.jsonl"
    done = mapr("catalog", "export", "--what", "bits", "--format", "jsonl", "--asset", "EMA1",
                "--fault", "esr", "-o", str(out), "--catalog", str(path))
    assert done.returncode == 0 and "3 bits written" in done.stderr
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    assert [r["flight"] for r in rows] == [9, 10, 11]
    assert rows[-1]["wear"] == {"esr": 0.66, "capacitance": 0.01}
    assert rows[-1]["health"]["modes"]["esr"]["evidenced"] is True


def test_episodes_and_events_export(tmp_path: Path) -> None:
    path = write_health_catalog(tmp_path / "c.sqlite")
    episodes = _csv(mapr("catalog", "export", "--what", "episodes", "--catalog",
                         str(path)).stdout)
    assert [(e["asset"], e["part"], e["modes"], e["state"], e["bits"]) for e in episodes] == [
        ("EMA1", "dc-link capacitor", "esr", "open", "3")]
    lines = mapr("catalog", "export", "--what", "episodes", "--format", "jsonl",
                 "--catalog", str(path)).stdout.splitlines()
    assert json.loads(lines[0])["modes"] == ["esr"]
    events = _csv(mapr("catalog", "export", "--catalog", str(path)).stdout)
    assert len(events) == 3 and json.loads(events[0]["evidence"]) == {
        "part": "dc-link capacitor"}
    jsonl = mapr("catalog", "export", "--format", "jsonl", "--catalog", str(path)).stdout
    assert [json.loads(x)["episode_id"] for x in jsonl.splitlines()] == [1, 1, 1]
