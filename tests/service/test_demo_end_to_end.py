"""``mapr demo`` end to end: the flight's BIT, cut out of the bus traffic, decided by the
reasoner, and the event in the fault catalog that ``mapr catalog list`` reads."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def mapr(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=300,
                          env={**os.environ, **(env or {})})


def test_the_demo_diagnoses_its_bit_and_writes_the_catalog(tmp_path: Path,
                                                           dictionary: Path) -> None:
    catalog = tmp_path / "demo.sqlite"
    # the single-EMA table: the aileron alone (both EMAs: tests/testbed/test_demo_two_ema.py)
    result = mapr("demo", "--word-level", "--show", "0", "--fault", "open=A_high",
                  "--icd", str(ROOT / "configs" / "icd" / "ema-testbed.yaml"),
                  "--dictionary", str(dictionary), "--catalog", str(catalog))
    assert result.returncode == 0, result.stderr
    assert "ANOMALY open/A_high" in result.stdout, result.stdout
    assert f"Fault catalog {catalog}: 1 BITs stored, event 1 written" in result.stdout
    listed = mapr("catalog", "list", "--catalog", str(catalog))
    assert listed.returncode == 0, listed.stderr
    assert "EMA1" in listed.stdout and "open/A_high" in listed.stdout


def test_a_short_demo_flight_says_why_nothing_was_diagnosed(tmp_path: Path) -> None:
    result = mapr("demo", "--word-level", "--seconds", "0.5", "--show", "0",
                  env={"MAPR_CACHE": str(tmp_path)})
    assert result.returncode == 0, result.stderr
    assert "No complete BIT in 0.5 s of flight" in result.stdout
    assert not list(tmp_path.iterdir()), "no dictionary is built when there is no BIT"


def test_a_missing_dictionary_is_one_line_and_exit_2(tmp_path: Path) -> None:
    result = mapr("demo", "--word-level", "--show", "0", "--dictionary",
                  str(tmp_path / "none.npz"))
    assert result.returncode == 2
    assert result.stderr.strip() == f"mapr demo: {tmp_path / 'none.npz'}: no such dictionary"
