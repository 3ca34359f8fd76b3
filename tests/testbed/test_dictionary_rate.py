"""A dictionary for an EMA sampled at the two-EMA bus's 1 kHz: ``mapr dictionary build
--sample-rate``, the rate the elevator's blocks carry (docs/testbed.md)."""

from __future__ import annotations

from pathlib import Path

import pytest

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.main import main
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary

ROOT = Path(__file__).resolve().parents[2]
TINY = """pressures_pa: [1600.0]
nominal_per_pressure: 2
severities: [0.5, 1.0]
kinds: [esr]
shorts: []
opens: []
healthy_runs: 48
calibration_runs: 12
envelope: true
"""


def test_a_dictionary_built_at_the_buss_rate(tmp_path: Path) -> None:
    spec = tmp_path / "spec.yaml"
    spec.write_text(TINY, encoding="utf-8")
    out = tmp_path / "elevator.npz"
    assert main(["dictionary", "build", "-o", str(out), "--spec", str(spec), "--jobs", "1",
                 "--actuator", str(ROOT / "configs/actuators/elevator-uav.yaml"),
                 "--sample-rate", "1000"]) == 0
    assert Dictionary.load(out).sample_rate_hz == 1000.0


def test_a_rate_the_plant_cannot_sample_at_is_refused(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "d.npz"
    code = main(["dictionary", "build", "-o", str(out), "--sample-rate", "1234.5"])
    assert code == exitcodes.CONFIG
    assert "rate" in capsys.readouterr().err and not out.exists()
