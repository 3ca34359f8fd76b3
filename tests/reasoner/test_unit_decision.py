"""An asset with its commissioning folder: the event's mode, part and severity come from the
reading against the unit's baseline when it explains the BIT, the dictionary's reading beside
it; without one the events are as before; a folder that cannot be used is one config error."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.errors import ConfigError
from mapr_daemon.findings import Diagnosis
from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.severity import Reading
from mapr_daemon.reasoner.commissioning.unit_decision import MIN_EXPLAINED, combine
from mapr_daemon.reasoner.diagnosis.classifier import Decision
from mapr_daemon.reasoner.reasoner import Reasoner
from tests.reasoner.conftest import HELD_OUT, Bench, commissioned_folder

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def unit(bench: Bench, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A commissioning folder made from six of the bench's healthy runs (the unit is the
    data sheet's twin here: what is tested is the wiring of the reading into the event)."""
    return commissioned_folder(bench, tmp_path_factory.mktemp("unit"))


def _held(bench: Bench, reasoner: Reasoner, j: int) -> Diagnosis:
    i = bench.runs.n - len(HELD_OUT) + j
    channels = {k: v[i] for k, v in bench.runs.channels.items()}
    return reasoner.diagnose(channels, bench.runs.command_deg,
                             float(bench.runs.dynamic_pressure_pa[i]))


def test_a_friction_fault_takes_its_severity_from_the_baseline_reading(
        bench: Bench, unit: Path) -> None:
    assert HELD_OUT[4][:2] == ("friction", 0.8)
    with_unit = _held(bench, Reasoner(bench.dictionary, bench.params,
                                      baseline=Baseline.load(unit)), 4)
    alone = _held(bench, Reasoner(bench.dictionary, bench.params), 4)
    ev = with_unit.evidence
    assert with_unit.anomaly and with_unit.fault == "friction"
    assert with_unit.part == "motor and gear"
    assert ev["reading"] == "baseline" and ev["baseline"]["explains"]
    assert abs(ev["severity_fraction_of_range"] - 0.8) < 0.1, ev
    # the event's severity is the friction multiplier the baseline read (1 + 4 x fraction)
    assert with_unit.severity == pytest.approx(1 + 4 * ev["baseline"]["severity"], rel=1e-3)
    # the dictionary's own reading is kept beside it, as the dictionary alone gives it
    assert ev["dictionary"]["fault"] == alone.fault
    assert ev["dictionary"]["severity"] == alone.severity
    assert "disagreement" not in ev
    assert "baseline" not in alone.evidence and "dictionary" not in alone.evidence


def test_a_bit_the_dictionary_calls_nominal_is_unchanged(bench: Bench, unit: Path) -> None:
    with_unit = _held(bench, Reasoner(bench.dictionary, bench.params,
                                      baseline=Baseline.load(unit)), 0)
    alone = _held(bench, Reasoner(bench.dictionary, bench.params), 0)
    assert not alone.anomaly
    assert with_unit.to_json() == alone.to_json()


def _decision(fault: str) -> Decision:
    return Decision(True, fault, None, 0.5, 0.01, "ohm", 0.9, 5.0, 1.0, {"x": 1})


def test_the_rule_follows_the_baseline_on_a_part_disagreement_and_falls_back_when_weak(
        unit: Path) -> None:
    baseline = Baseline.load(unit)
    strong = Reading("friction", "", 0.4, cost=1.2, healthy_cost=30.0, costs={})
    dec = combine(_decision("esr"), strong, baseline)
    assert (dec.fault, dec.severity) == ("friction", 0.4)
    assert dec.value == pytest.approx(1 + 4 * 0.4)
    assert dec.evidence["disagreement"]["dictionary_part"] == "SMPS output capacitor"
    assert dec.evidence["disagreement"]["baseline_part"] == "motor and gear"
    assert dec.evidence["dictionary"]["fault"] == "esr" and dec.evidence["x"] == 1
    # a fault that explains less than a healthy BIT's scatter does not decide
    weak = Reading("friction", "", 0.4, cost=1.0, healthy_cost=1.0 + 0.5 * MIN_EXPLAINED,
                   costs={})
    kept = combine(_decision("esr"), weak, baseline)
    assert (kept.fault, kept.severity) == ("esr", 0.5)
    assert kept.evidence["reading"] == "dictionary" and not kept.evidence["baseline"]["explains"]
    # nor one that leaves most of the departure unexplained
    partial = Reading("friction", "", 0.4, cost=20.0, healthy_cost=30.0, costs={})
    assert combine(_decision("esr"), partial, baseline).fault == "esr"
    # a short read against the baseline names its switch, no severity fraction
    short = combine(_decision("esr"), Reading("short", "B_low", 1.0, 2.0, 50.0, {}), baseline)
    assert (short.fault, short.switch, short.severity, short.value) == ("short", "B_low",
                                                                        None, None)


def _config(bench: Bench, tmp_path: Path, folder: Path) -> object:
    from mapr_daemon.service.config import Config
    dpath = tmp_path / "d.npz"
    if not dpath.exists():
        bench.dictionary.save(dpath)
    return dataclasses.replace(
        Config(), source="x.yaml",
        assets=(dataclasses.replace(Config().assets[0], commissioned=str(folder)),),
        reasoner=dataclasses.replace(Config().reasoner, dictionary=str(dpath)))


def test_an_unusable_commissioning_folder_is_one_config_error_naming_the_file(
        bench: Bench, unit: Path, tmp_path: Path) -> None:
    from mapr_daemon.pipeline.pipeline import build_pipeline

    good = build_pipeline(_config(bench, tmp_path, unit), trend=False)   # type: ignore[arg-type]
    assert good.watched[0].watch is not None
    assert good.watched[0].watch.reasoner.baseline is not None
    broken = tmp_path / "broken"
    broken.mkdir()
    for name in ("actuator.yaml", "commissioning.json"):
        (broken / name).write_bytes((unit / name).read_bytes())
    (broken / "discrepancy.npz").write_bytes(b"not an npz")
    with pytest.raises(ConfigError) as caught:
        build_pipeline(_config(bench, tmp_path, broken), trend=False)   # type: ignore[arg-type]
    message = str(caught.value)
    assert message.startswith("x.yaml: assets[0].commissioned: ")
    assert str(broken / "discrepancy.npz") in message and len(message.splitlines()) == 1
    # a file cut short (a copy interrupted): still one line naming it, not a traceback
    whole = (unit / "discrepancy.npz").read_bytes()
    (broken / "discrepancy.npz").write_bytes(whole[: len(whole) // 2])
    with pytest.raises(ConfigError) as caught:
        build_pipeline(_config(bench, tmp_path, broken), trend=False)   # type: ignore[arg-type]
    assert str(broken / "discrepancy.npz") in str(caught.value)
    # a missing folder stops `mapr run --check` with the config exit code, in one line
    config = tmp_path / "mapr.yaml"
    config.write_text(f"reasoner:\n  dictionary: {tmp_path / 'd.npz'}\nassets:\n"
                      f"  - name: EMA1\n    rt: 5\n    commissioned: {tmp_path / 'gone'}\n"
                      f"catalog:\n  path: {tmp_path / 'catalog.db'}\n")
    done = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "run", "--check",
                           "--config", str(config)], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 78, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "assets[0].commissioned: " in lines[0]
    assert str(tmp_path / "gone" / "commissioning.json") + ": no such file" in lines[0]


def test_no_second_reading_without_a_commissioning_folder(bench: Bench) -> None:
    r = Reasoner(bench.dictionary, bench.params)
    assert r.baseline is None
    d = _held(bench, r, 4)
    assert not {"baseline", "dictionary", "reading"} & set(d.evidence)
    assert np.isfinite(d.confidence)


def test_the_config_key_is_read_relative_to_the_config_file(tmp_path: Path) -> None:
    from mapr_daemon.service.config import load_config

    path = tmp_path / "mapr.yaml"
    path.write_text("assets:\n  - {name: EMA1, rt: 5, commissioned: units/ema1}\n")
    assert load_config(path).assets[0].commissioned == str(tmp_path / "units" / "ema1")
