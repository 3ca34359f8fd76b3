"""Per-RT/SA statistics in the catalog: written per interval, folded per key when read."""

from __future__ import annotations

import dataclasses
import json
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest

from drivers.mil1553.record import MonitorRecord, TransferFormat
from drivers.rtstats import TrafficStatistics
from mapr_daemon.catalog import CatalogReader, CatalogWriter
from mapr_daemon.catalog.rt_stats import RT_STATS_SINCE
from mapr_daemon.catalog.schema import MIGRATIONS, migrate

from .conftest import T0

ROOT = Path(__file__).resolve().parents[2]
S = 10**9


def interval(gaps: list[int | None], t0: int = 0) -> list[dict[str, object]]:
    """The rows of one interval: RT 5 R SA 1 once per gap (None: no response), and one
    mode code (RT 5 T MC 2) answered in 7 µs."""
    records = [MonitorRecord(t_ns=t0 + i * 1000, bus="A", format=TransferFormat.BC_RT,
                             command=5 << 11 | 1 << 5 | 2, data=(0, 0),
                             status=() if g is None else (5 << 11,),
                             gaps_ns=() if g is None else (g,),
                             errors=("no_response",) if g is None else ())
               for i, g in enumerate(gaps)]
    records.append(MonitorRecord(t_ns=t0 + 99_000, bus="B", format=TransferFormat.MODE,
                                 command=5 << 11 | 1 << 10 | 2, status=(5 << 11,),
                                 gaps_ns=(7000,)))
    stats = TrafficStatistics()
    stats.add_batch(records)
    return [dataclasses.asdict(r) for r in stats.rows()]


def write(path: Path) -> None:
    with CatalogWriter(path) as writer:
        writer.open_session(backend="loopback", config_hash="cafe", started_ns=T0)
        writer.add_rt_stats(T0, T0 + 10 * S, interval([5000, 6000, None]))
        writer.add_rt_stats(T0 + 10 * S, T0 + 20 * S, interval([8000]))
        writer.add_rt_stats(T0 + 20 * S, T0 + 30 * S, [])        # a silent interval


def test_intervals_fold_into_one_row_per_key(tmp_path: Path) -> None:
    path = tmp_path / "c.sqlite"
    write(path)
    with CatalogReader(path) as reader:
        rows = {r.label: r for r in reader.rt_stats()}
        later = {r.label: r for r in reader.rt_stats(since_ns=T0 + 10 * S)}
    sa, mc = rows["RT05 R SA01"], rows["RT05 T MC02"]
    assert (sa.messages, sa.wc, sa.errors) == (4, 2, {"no_response": 1})
    assert sa.response_mean_us == pytest.approx(19000 / 3 / 1e3)   # exact, not a mean of means
    assert (sa.response_min_us, sa.response_max_us) == (5.0, 8.0)
    assert sa.rate_hz == pytest.approx(4 / 20)     # over the 20 s of intervals with traffic
    assert sa.last_seen_ns == T0 + 20 * S
    assert (mc.mode_code, mc.wc, mc.messages, mc.response_mean_us) == (2, None, 2, 7.0)
    assert later["RT05 R SA01"].messages == 1 and later["RT05 R SA01"].errors == {}


def test_a_catalog_from_before_the_table_reads_empty_then_migrates(tmp_path: Path) -> None:
    path = tmp_path / "old.sqlite"
    conn = sqlite3.connect(path, isolation_level=None)
    migrate(conn, str(path), MIGRATIONS[:RT_STATS_SINCE - 1])
    conn.close()
    with CatalogReader(path) as reader:
        assert reader.schema_version == RT_STATS_SINCE - 1 and reader.rt_stats() == []
    write(path)                                  # the writer migrates it forward
    with CatalogReader(path) as reader:
        assert [r.messages for r in reader.rt_stats()] == [4, 2]


def test_catalog_stats_by_rt_text_and_json(tmp_path: Path) -> None:
    path = tmp_path / "c.sqlite"
    write(path)

    def mapr(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args], cwd=ROOT,
                              capture_output=True, text=True, timeout=60, check=False)

    text = mapr("catalog", "stats", "--catalog", str(path), "--by-rt")
    assert text.returncode == 0, text.stderr
    lines = text.stdout.splitlines()
    assert lines[0].split()[:3] == ["RT/SA", "WC", "MESSAGES"]
    assert lines[1].split()[:5] == ["RT05", "R", "SA01", "2", "4"]
    assert "no_response 1" in lines[1] and lines[2].split()[:3] == ["RT05", "T", "MC02"]
    as_json = json.loads(mapr("catalog", "--catalog", str(path), "--json", "stats",
                              "--by-rt").stdout)
    assert [r["messages"] for r in as_json["rt_sa"]] == [4, 2]
