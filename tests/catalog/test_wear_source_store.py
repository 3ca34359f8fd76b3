"""Which path read each BIT's wear (schema v10): stored, read back, exported; a catalog from
before opens as it is, migrates, and keeps its old BITs' source unknown (``{}``)."""

from __future__ import annotations

import csv
import io
import json
import sqlite3
from pathlib import Path

from mapr_daemon.catalog import BitOutcome, CatalogReader, CatalogWriter
from mapr_daemon.catalog.schema import LATEST, MIGRATIONS, migrate
from tests.catalog.test_catalog_cli import mapr

from .conftest import T0

BASELINE = {"path": "baseline", "record": "0123456789abcdef", "offset": 0.03, "sd0": 0.05,
            "sd1": 0.01}


def _v9_file_with_a_bit(path: Path) -> None:
    """What MAPR with schema v9 left: one BIT of EMA1 with its wear and no source."""
    conn = sqlite3.connect(path, isolation_level=None)
    migrate(conn, str(path), steps=MIGRATIONS[:9])
    conn.execute("INSERT INTO bits (tail, asset, t_ns, flight, wear) VALUES "
                 "('N101', 'EMA1', ?, 1, '{\"esr\": 0.1, \"friction\": 0.2}')", (T0,))
    conn.close()


def test_an_old_catalog_keeps_its_bits_source_unknown_and_new_bits_store_theirs(
        tmp_path: Path) -> None:
    path = tmp_path / "v9.sqlite"
    _v9_file_with_a_bit(path)
    with CatalogReader(path) as reader:   # read as it is, without the column
        assert reader.schema_version == 9
        (old,) = reader.bits()
        assert dict(old.wear) == {"esr": 0.1, "friction": 0.2} and dict(old.wear_source) == {}
    with CatalogWriter(path) as writer:   # migrated
        writer.open_session(backend="replay", config_hash="x")
        writer.add_bits([BitOutcome("EMA1", T0 + 10**12, tail="N101", flight=2,
                                    wear={"esr": 0.13, "friction": 0.21},
                                    wear_source={"esr": BASELINE,
                                                 "friction": {"path": "estimator"}})])
    with CatalogReader(path) as reader:
        assert reader.schema_version == LATEST >= 10
        old, new = reader.bits(asset="EMA1")
        assert dict(old.wear_source) == {}
        assert dict(new.wear_source) == {"esr": BASELINE, "friction": {"path": "estimator"}}


def test_the_export_says_which_path_read_each_kind(tmp_path: Path) -> None:
    path = tmp_path / "v9.sqlite"
    _v9_file_with_a_bit(path)
    with CatalogWriter(path) as writer:
        writer.open_session(backend="replay", config_hash="x")
        writer.add_bits([BitOutcome("EMA1", T0 + 10**12, tail="N101", flight=2,
                                    wear={"esr": 0.13, "friction": 0.21},
                                    wear_source={"esr": BASELINE,
                                                 "friction": {"path": "estimator"}})])
    done = mapr("catalog", "export", "--what", "bits", "--format", "csv",
                "--catalog", str(path))
    assert done.returncode == 0, done.stderr
    rows = list(csv.DictReader(io.StringIO(done.stdout)))
    assert [(r["source_esr"], r["source_friction"]) for r in rows] == [
        ("", ""), ("baseline:0123456789abcdef", "estimator")]
    done = mapr("catalog", "export", "--what", "bits", "--format", "jsonl",
                "--catalog", str(path))
    assert done.returncode == 0, done.stderr
    lines = [json.loads(line) for line in done.stdout.splitlines()]
    assert [line["wear_source"] for line in lines] == [
        {}, {"esr": BASELINE, "friction": {"path": "estimator"}}]


def test_a_malformed_stored_source_is_read_as_unknown_not_a_crash(tmp_path: Path) -> None:
    """A ``wear_source`` cell that is not a map of kind to source (a file edited or damaged
    by hand) must not stop the daemon resuming, ``mapr health`` or the export: each kind
    whose entry is not a source reads as unknown (the asset's path now), the rest as
    stored."""
    from mapr_daemon.pipeline.trending import history_from_bits

    path = tmp_path / "c.sqlite"
    cells = ['{"esr": "estimator", "friction": {"path": "estimator"}}', '{"esr": null}',
             '["estimator"]', '"estimator"', 'null', '{"esr": 1', '']
    with CatalogWriter(path) as writer:
        writer.open_session(backend="replay", config_hash="x")
        writer.add_bits([BitOutcome("EMA1", T0 + i * 10**12, tail="N101", flight=i + 1,
                                    wear={"esr": 0.1, "friction": 0.2})
                         for i in range(len(cells))])
    conn = sqlite3.connect(path, isolation_level=None)
    for i, cell in enumerate(cells):
        conn.execute("UPDATE bits SET wear_source = ? WHERE flight = ?", (cell, i + 1))
    conn.close()
    with CatalogWriter(path) as writer:   # what the daemon reads to resume the trend
        bits, _, _ = writer.history("N101")
    assert [dict(b.wear_source) for b in bits] == [
        {"friction": {"path": "estimator"}}, {}, {}, {}, {}, {}, {}]
    history = history_from_bits(bits)["EMA1"]
    assert history.sources == [{"friction": {"path": "estimator"}}] + [None] * 6
    for what in (("health",), ("catalog", "trend", "N101/EMA1", "--json"),
                 ("catalog", "export", "--what", "bits", "--format", "csv"),
                 ("catalog", "export", "--what", "bits", "--format", "jsonl")):
        done = mapr(*what, "--catalog", str(path))
        assert done.returncode == 0, (what, done.stderr)
