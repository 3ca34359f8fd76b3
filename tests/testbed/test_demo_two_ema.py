"""``mapr demo`` flies the aileron and the elevator on one bus, seeds a fault on one, and
diagnoses and trends both through the daemon's pipeline: each actuator's diagnosis and health
line, and the catalog ``mapr health`` reads (one open episode, on the faulted one only)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mapr_daemon.catalog import CatalogReader

ROOT = Path(__file__).resolve().parents[2]


def mapr(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=600,
                          env={**os.environ, **(env or {})})


@pytest.fixture(scope="module")
def models(small_models: Path) -> list[str]:
    """``--dictionary D --prognosis P`` for the aileron (2 kHz) and the elevator (1 kHz)."""
    return [arg for surface, option in (("aileron", ""), ("elevator", "elevator-"))
            for kind in ("dictionary", "prognosis")
            for arg in (f"--{option}{kind}", str(small_models / f"{surface}-{kind}.npz"))]


def test_the_demo_diagnoses_and_trends_both_emas(tmp_path: Path, models: list[str]) -> None:
    catalog = tmp_path / "demo.sqlite"
    result = mapr("demo", "--word-level", "--show", "0", "--faulted", "elevator", "--fault",
                  "esr=0.6", *models, "--catalog", str(catalog),
                  env={"MAPR_CACHE": str(tmp_path / "cache")})
    assert result.returncode == 0, result.stderr
    out = result.stdout
    assert "aileron EMA (EMA1, RT 5, 2 kHz) healthy; elevator EMA (EMA2, RT 7, 1 kHz) esr=0.6" \
        in out, out
    ail, elev = out.split("EMA1 (aileron EMA, RT 5):\n")[1].split("EMA2 (elevator EMA, RT 7):\n")
    assert ": nominal" in ail and "ANOMALY" not in ail, out
    assert "ANOMALY esr" in elev.split("\n\n")[0], out
    # the health lines, as `mapr health` prints them: both actuators, SoH per actuator
    lines = out.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("ACTUATOR"))
    table = lines[start:start + 3]
    assert [line.split()[0] for line in table] == ["ACTUATOR", "EMA1", "EMA2"], out
    assert "1 open (SMPS output capacitor)" in table[2] and "none" in table[1], out
    assert "2 BITs stored, event 1 written" in out
    assert not (tmp_path / "cache").exists(), "nothing is built when every file is given"
    with CatalogReader(catalog) as reader:
        episodes = reader.episodes(open_only=True)
        bits = {b.asset: b for b in reader.bits()}
    assert [(ep.asset, ep.mode) for ep in episodes] == [("EMA2", "esr")]
    assert bits["EMA1"].fault is None and bits["EMA2"].fault == "esr"
    assert bits["EMA1"].health.soh is not None and bits["EMA2"].health.soh is not None
    health = mapr("health", "--json", "--catalog", str(catalog))
    assert health.returncode == 0, health.stderr
    assert [row["asset"] for row in json.loads(health.stdout)] == ["EMA1", "EMA2"]


def test_a_table_without_the_elevator_flies_the_aileron_alone(tmp_path: Path,
                                                              models: list[str]) -> None:
    result = mapr("demo", "--word-level", "--show", "0", "--icd",
                  str(ROOT / "configs" / "icd" / "ema-testbed.yaml"), *models[:4],
                  "--catalog", str(tmp_path / "one.sqlite"))
    assert result.returncode == 0, result.stderr
    assert "elevator" not in result.stdout.split("\n", 1)[0]
    assert "EMA1 (aileron EMA, RT 5):" in result.stdout and "EMA2" not in result.stdout
    assert "ANOMALY esr" in result.stdout      # the default fault, on the aileron
    bad = mapr("demo", "--word-level", "--show", "0", "--icd",
               str(ROOT / "configs" / "icd" / "ema-testbed.yaml"), "--faulted", "elevator")
    assert bad.returncode == 2
    assert "has no elevator EMA (RT 7) to seed the fault on" in bad.stderr


def test_a_missing_model_file_is_one_line_and_exit_2(tmp_path: Path) -> None:
    result = mapr("demo", "--word-level", "--show", "0", "--elevator-prognosis",
                  str(tmp_path / "none.npz"))
    assert result.returncode == 2
    assert result.stderr.strip() == f"mapr demo: {tmp_path / 'none.npz'}: no such model"
