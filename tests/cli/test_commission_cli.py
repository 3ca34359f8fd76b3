"""`mapr commission` end to end: simulated healthy BIT files of a unit, a tiny dictionary spec."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from mapr_daemon.cli.main import main
from mapr_daemon.ema.dump import write_actuator
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.commissioning import prior as ip
from mapr_daemon.reasoner.commissioning.record import read_record
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory, commission_settings: Path) -> Path:
    """The settings (spec.yaml, tolerances.yaml), a unit's two healthy BITs and a flight."""
    d = tmp_path_factory.mktemp("commission")
    sheet = load_actuator(default_actuator_path())
    unit = ip.scaled(sheet, {"motor.back_emf_v_s_per_rad": 1.04, "motor.inertia_kg_m2": 0.88})
    write_actuator(d / "unit.yaml", unit)
    for name in ("spec.yaml", "tolerances.yaml"):
        (d / name).write_text((commission_settings / name).read_text())
    for i, (q, amb, bus) in enumerate([(400, -10, 27.9), (1600, 35, 27.2)]):
        assert main(["simulate", "--actuator", str(d / "unit.yaml"), "--profile", "bit",
                     "--pressure", str(q), "--ambient", str(amb), "--bus-voltage", str(bus),
                     "--seed", str(i + 1), "-o", str(d / f"bit{i}.npz")]) == 0
    assert main(["simulate", "--actuator", str(d / "unit.yaml"), "--profile", "jsbsim",
                 "--duration", "0.5", "-o", str(d / "flight.npz")]) == 0
    return d


def test_commission_writes_actuator_record_and_dictionary(
        files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "unit42"
    rc = main(["commission", "--actuator", str(default_actuator_path()),
               str(files / "bit0.npz"), str(files / "flight.npz"), str(files / "bit1.npz"),
               "--tolerances", str(files / "tolerances.yaml"), "--spec",
               str(files / "spec.yaml"), "-o", str(out)])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    skipped = [line for line in cap.err.splitlines() if "skipped" in line]
    assert len(skipped) == 1 and "flight.npz" in skipped[0], cap.err
    ident = load_actuator(out / "actuator.yaml")
    assert math.log(ident.motor.back_emf_v_s_per_rad / 0.0312) == pytest.approx(0, abs=0.01)
    assert math.log(ident.motor.inertia_kg_m2 / 5.28e-6) == pytest.approx(0, abs=0.02)
    rec = read_record(out / "commissioning.json")
    assert [b.source for b in rec.bits] == [str(files / "bit0.npz"), str(files / "bit1.npz")]
    assert rec.dictionary == "dictionary.npz" and rec.identified_actuator == "actuator.yaml"
    assert rec.skipped == ()
    # two BITs leave none to hold out: no discrepancy is learned, and it says so
    assert rec.discrepancy is None and not (out / "discrepancy.npz").exists()
    assert "2 BITs: learning the model's discrepancy needs at least 3" in cap.err
    assert [e.path for e in rec.parameters] == ["motor.back_emf_v_s_per_rad",
                                                "motor.inertia_kg_m2"]
    d = Dictionary.load(out / "dictionary.npz")
    assert d.actuator == ident.name
    assert json.loads((out / "commissioning.json").read_text())["format"] == \
        "mapr-commissioning/1"
    assert "motor.inertia_kg_m2" in cap.out and "yes" in cap.out


def test_exit_codes(files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sheet = str(default_actuator_path())
    out = str(tmp_path / "o")
    assert main(["commission", "--actuator", sheet, str(files / "nope.npz"), "-o", out]) == 2
    assert "nope.npz" in capsys.readouterr().err
    (tmp_path / "bad.yaml").write_text("name: x\n")
    assert main(["commission", "--actuator", str(tmp_path / "bad.yaml"),
                 str(files / "bit0.npz"), "-o", out]) == 78
    capsys.readouterr()
    # input that is not there (a file of no BITs): one line naming it, exit 65
    assert main(["commission", "--actuator", sheet, str(files / "flight.npz"), "-o", out]) == 65
    (err,) = capsys.readouterr().err.strip().splitlines()
    assert err.startswith(f"mapr commission: {files / 'flight.npz'}: no BIT to commission "
                          "from: ")
    (tmp_path / "junk.npz").write_text("not a zip")
    assert main(["commission", "--actuator", sheet, str(tmp_path / "junk.npz"), "-o", out]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
