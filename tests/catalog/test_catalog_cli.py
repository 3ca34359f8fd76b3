"""`mapr catalog` as a maintainer and a script use it, on real catalog files."""

from __future__ import annotations

import csv
import io
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mapr_daemon.catalog import CatalogReader, EventFilter
from mapr_daemon.cli import exitcodes

ROOT = Path(__file__).resolve().parents[2]


def mapr(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=60, check=False,
                          env={**os.environ, **(env or {})})


def test_list_table_and_json_agree_with_the_reader(filled: Path) -> None:
    text = mapr("catalog", "list", "--catalog", str(filled), "--asset", "EMA1",
                "--min-severity", "0.3", "--limit", "0")
    assert text.returncode == 0, text.stderr
    lines = text.stdout.splitlines()
    assert lines[0].split() == ["ID", "TIME", "(UTC)", "ASSET", "RT", "FAULT", "SEVERITY",
                                "CONF", "SOH", "RUL"]
    with CatalogReader(filled) as reader:
        expected = reader.events(EventFilter(asset="EMA1", min_severity=0.3))
    assert [int(line.split()[0]) for line in lines[1:]] == [e.id for e in expected]
    as_json = mapr("catalog", "--catalog", str(filled), "--json", "list", "--asset", "EMA1",
                   "--min-severity", "0.3")
    rows = json.loads(as_json.stdout)
    assert [r["id"] for r in rows] == [e.id for e in expected]
    assert all(r["asset"] == "EMA1" for r in rows)


def test_list_limit_says_there_is_more_and_env_names_the_catalog(filled: Path) -> None:
    result = mapr("catalog", "list", "--limit", "3", env={"MAPR_CATALOG": str(filled)})
    assert result.returncode == 0, result.stderr
    assert len(result.stdout.splitlines()) == 5
    assert "--limit 0 for all" in result.stdout.splitlines()[-1]
    none = mapr("catalog", "list", "--fault", "nonexistent", env={"MAPR_CATALOG": str(filled)})
    assert none.stdout.startswith("no events in")


def test_show_and_a_missing_id(filled: Path) -> None:
    shown = mapr("catalog", "show", "7", "--catalog", str(filled))
    assert shown.returncode == 0, shown.stderr
    assert shown.stdout.startswith("event 7\n  time        2026-05-09 04:19:20Z")
    assert "session     1: loopback, config cafe" in shown.stdout and "SIGTERM" in shown.stdout
    as_json = json.loads(mapr("catalog", "show", "7", "--json", "--catalog", str(filled)).stdout)
    assert (as_json["id"], as_json["session"]["stop_reason"]) == (7, "SIGTERM")
    missing = mapr("catalog", "show", "999", "--catalog", str(filled))
    assert missing.returncode == exitcodes.USAGE
    assert missing.stderr == f"mapr catalog show: no event 999 in {filled}\n"


def test_export_csv_and_json(filled: Path, tmp_path: Path) -> None:
    out = tmp_path / "faults.csv"
    done = mapr("catalog", "export", "--format", "csv", "-o", str(out), "--fault", "esr",
                "--catalog", str(filled))
    assert done.returncode == 0, done.stderr
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert rows and all(r["fault"] == "esr" for r in rows)
    assert json.loads(rows[0]["params"])["capacitance_f"] == 2.88e-4
    assert f"{len(rows)} events written" in done.stderr
    as_json = json.loads(mapr("catalog", "export", "--format", "json", "--catalog",
                              str(filled)).stdout)
    assert len(as_json) == 40 and [r["id"] for r in as_json] == sorted(r["id"] for r in as_json)
    empty = mapr("catalog", "export", "--format", "json", "--asset", "none", "--catalog",
                 str(filled))
    assert json.loads(empty.stdout) == []


def test_trend_table_json_and_plot(filled: Path, tmp_path: Path) -> None:
    trend = mapr("catalog", "trend", "EMA2", "--catalog", str(filled), "--json")
    points = json.loads(trend.stdout)
    assert points and all(p["soh"] is not None for p in points)
    assert [p["t_ns"] for p in points] == sorted(p["t_ns"] for p in points)
    unknown = mapr("catalog", "trend", "EMA9", "--catalog", str(filled))
    # an actuator the catalog does not hold is a usage error naming those it holds
    assert unknown.returncode == 2 and unknown.stdout == ""
    assert "EMA9" in unknown.stderr and "EMA1" in unknown.stderr
    assert len(unknown.stderr.strip().splitlines()) == 1, unknown.stderr
    pytest.importorskip("matplotlib", reason="--plot needs matplotlib (optional)")
    png = tmp_path / "trend.png"
    plotted = mapr("catalog", "trend", "EMA2", "--plot", str(png), "--catalog", str(filled))
    assert plotted.returncode == 0, plotted.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_stats_shows_intervals_and_gaps(filled: Path) -> None:
    text = mapr("catalog", "stats", "--catalog", str(filled))
    assert text.returncode == 0, text.stderr
    lines = text.stdout.splitlines()
    assert lines[0].split()[:4] == ["START", "(UTC)", "LENGTH", "BUS"]
    assert lines[5].split()[-3:] == ["2", "parity", "2"]
    assert "backend: USB card unplugged" in lines[-1]
    data = json.loads(mapr("catalog", "stats", "--json", "--bus", "A", "--catalog",
                           str(filled)).stdout)
    assert [r["errors_total"] for r in data["intervals"]] == [0, 1, 2]
    assert len(data["gaps"]) == 1


@pytest.mark.parametrize("content", [None, b"garbage, not SQLite" * 300],
                         ids=["missing", "corrupt"])
def test_missing_or_corrupt_catalog_is_one_line_and_exit_66(tmp_path: Path,
                                                            content: bytes | None) -> None:
    path = tmp_path / "catalog.sqlite"
    if content is not None:
        path.write_bytes(content)
    result = mapr("catalog", "list", "--catalog", str(path))
    assert result.returncode == exitcodes.NOINPUT == 66
    assert result.stdout == ""
    assert len(result.stderr.splitlines()) == 1
    assert result.stderr.startswith(f"mapr catalog list: {path}: ")


def test_bad_arguments_are_usage_errors(filled: Path) -> None:
    for args in (["--since", "yesterday"], ["--min-severity", "2"]):
        result = mapr("catalog", "list", "--catalog", str(filled), *args)
        assert result.returncode == exitcodes.USAGE
        assert len(result.stderr.splitlines()) == 1
