"""Commissioning's identification on our own plant: a unit with known parameters, a few BITs.

One module-level batch (three healthy BITs of a perturbed unit at different conditions and one
BIT of the same unit with friction x3) is simulated once; the fits identify four motor-side
parameters (few parameters keep the test to seconds).
"""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.ema.dump import dump_actuator
from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.ema.params import (
    ActuatorParams,
    default_actuator_path,
    load_actuator,
    parse_actuator,
)
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning import prior as ip
from mapr_daemon.reasoner.commissioning.bits import BitRecord, from_runs, unusable
from mapr_daemon.reasoner.commissioning.identify import Identification, identify
from mapr_daemon.reasoner.commissioning.record import (
    CommissioningRecord,
    read_record,
    write_record,
)
from mapr_daemon.reasoner.training.corpus import simulate_bit

TRUE_FACTORS = {"motor.resistance_ohm": 1.08, "motor.back_emf_v_s_per_rad": 0.96,
                "motor.inertia_kg_m2": 1.12, "gear.efficiency": 0.96}
TOLERANCES = (ip.Tolerance("motor.resistance_ohm", 10, 10),
              ip.Tolerance("motor.back_emf_v_s_per_rad", 5, 5),
              ip.Tolerance("motor.inertia_kg_m2", 15, 15),
              ip.Tolerance("gear.efficiency", 5, 5))
BOUNDS = {"motor.resistance_ohm": 0.03, "motor.back_emf_v_s_per_rad": 0.01,
          "motor.inertia_kg_m2": 0.02, "gear.efficiency": 0.015}
"""Largest |log(identified / true)| accepted from two BITs (the data sheet is 4-12 % off)."""


@dataclasses.dataclass
class Unit:
    datasheet: ActuatorParams
    truth: ActuatorParams
    bits: list[BitRecord]


@pytest.fixture(scope="module")
def unit() -> Unit:
    datasheet = load_actuator(default_actuator_path())
    truth = ip.scaled(datasheet, TRUE_FACTORS)
    runs = simulate_bit(truth, [FaultSet(), FaultSet(), FaultSet(),
                                FaultSet.of([Fault("friction", 3.0)])],
                        [300.0, 1800.0, 1000.0, 900.0], [11, 12, 13, 14],
                        ambient_c=[-15.0, 45.0, 20.0, 10.0], bus_v=[27.8, 26.5, 28.2, 27.0])
    return Unit(datasheet, truth, from_runs(runs, "unit.npz"))


@pytest.fixture(scope="module")
def fitted(unit: Unit) -> Identification:
    return identify(unit.datasheet, unit.bits[:2], TOLERANCES)


def test_two_bits_identify_the_motor_side(unit: Unit, fitted: Identification) -> None:
    for e in fitted.estimates:
        true = ip.get(unit.truth, e.path)
        error = math.log(e.value / true)
        assert e.identifiable, e.path
        assert abs(error) < BOUNDS[e.path], (e.path, error)
        # the data sheet was further off than the bound: the fit moved it
        assert abs(math.log(e.datasheet / true)) > BOUNDS[e.path]
        assert 0.0 < e.sd_rel < 0.5 * e.prior_sd_rel
        assert ip.get(fitted.params, e.path) == e.value
    assert fitted.residual_after["position_deg"] < 0.2 * fitted.residual_before["position_deg"]
    assert [(b.source, b.index) for b in fitted.bits] == [("unit.npz", 0), ("unit.npz", 1)]
    assert fitted.skipped == ()


def test_conditions_are_read_from_the_record(fitted: Identification) -> None:
    ambient = [b.ambient_c for b in fitted.bits]
    bus = [b.bus_v for b in fitted.bits]
    assert ambient == pytest.approx([-15.0, 45.0], abs=0.3)
    # the bus mean over the BIT, which drifts around its flight mean (sd 0.3 V)
    assert bus == pytest.approx([27.8, 26.5], abs=1.0)


def _broken(bit: BitRecord, **changes: object) -> BitRecord:
    return dataclasses.replace(bit, **changes)  # type: ignore[arg-type]


def test_unusable_bits_say_why(unit: Unit) -> None:
    p, bit = unit.datasheet, unit.bits[0]
    assert unusable(p, bit) is None
    nan = dict(bit.channels)
    nan["position_deg"] = nan["position_deg"].copy()
    nan["position_deg"][100] = np.nan
    assert unusable(p, _broken(bit, channels=nan)) == "non-finite values in position_deg"
    assert "sampled at 1000 Hz" in str(unusable(p, _broken(bit, sample_rate_hz=1000.0)))
    still = np.zeros_like(bit.command_deg)
    assert unusable(p, _broken(bit, command_deg=still)) == \
        "the command does not move: not a BIT"
    missing = {k: v for k, v in bit.channels.items() if k != "ripple_rms_v"}
    assert unusable(p, _broken(bit, channels=missing)) == "no ripple_rms_v channel"


def test_bad_and_faulty_bits_are_skipped_the_rest_identify(unit: Unit) -> None:
    bit = unit.bits[2]
    nan = {k: v.copy() for k, v in bit.channels.items()}
    nan["dc_link_current_a"][5] = np.inf
    bits = [unit.bits[0], _broken(bit, channels=nan), unit.bits[1], unit.bits[3]]
    got = identify(unit.datasheet, bits, TOLERANCES)
    reasons = dict(got.skipped)
    assert set(reasons) == {"unit.npz#2", "unit.npz#3"}
    assert reasons["unit.npz#2"] == "non-finite values in dc_link_current_a"
    assert reasons["unit.npz#3"].startswith("faulty-looking: friction x")
    assert [b.index for b in got.bits] == [0, 1]
    r = got.estimates[0]
    assert abs(math.log(r.value / ip.get(unit.truth, r.path))) < BOUNDS[r.path]


def test_no_usable_bit_is_one_config_error(unit: Unit) -> None:
    with pytest.raises(ConfigError, match=re.escape("no usable BIT: unit.npz#0: sampled at")):
        identify(unit.datasheet, [_broken(unit.bits[0], sample_rate_hz=500.0)], TOLERANCES)


def test_identified_actuator_file_reads_back(fitted: Identification) -> None:
    text = dump_actuator(fitted.params, "identified\nfrom two BITs",
                         {"motor.resistance_ohm": "identified"})
    assert parse_actuator(text) == fitted.params
    assert text.startswith("# identified\n# from two BITs\n")


def test_record_round_trips(fitted: Identification, tmp_path: Path) -> None:
    rec = CommissioningRecord.of(fitted, TOLERANCES, "datasheet.yaml", "actuator.yaml", None)
    write_record(tmp_path / "c.json", rec)
    assert read_record(tmp_path / "c.json") == rec
    (tmp_path / "old.json").write_text('{"format": "mapr-commissioning/0"}')
    with pytest.raises(ConfigError, match="expected format mapr-commissioning/1"):
        read_record(tmp_path / "old.json")
    (tmp_path / "cut.json").write_text('{"format": "mapr-commissioning/1", "created": "x"}')
    with pytest.raises(ConfigError, match="malformed commissioning record"):
        read_record(tmp_path / "cut.json")


def test_tolerance_file(unit: Unit) -> None:
    text = ("format: mapr-tolerances/1\nparameters:\n  motor.resistance_ohm: 10\n"
            "  smps.capacitance_f: [-10, 20]\n")
    r, c = ip.parse_tolerances(text, params=unit.datasheet)
    assert (r.minus_pct, r.plus_pct, r.prior_mean) == (10.0, 10.0, pytest.approx(-0.005, abs=1e-3))
    assert c.prior_mean == pytest.approx(0.5 * math.log(0.9 * 1.2))
    assert c.prior_sd == pytest.approx((math.log(1.2) - math.log(0.9)) / 4)
    shipped = ip.load_tolerances(ip.default_tolerances_path(), unit.datasheet)
    assert shipped == ip.DEFAULT_TOLERANCES
    bad = text.replace("motor.resistance_ohm", "motor.resistence_ohm")
    with pytest.raises(ConfigError, match=re.escape("parameters.motor.resistence_ohm")):
        ip.parse_tolerances(bad, params=unit.datasheet)
    with pytest.raises(ConfigError, match=re.escape("sensors.step_s")):
        ip.parse_tolerances(text.replace("motor.resistance_ohm", "sensors.step_s"),
                            params=unit.datasheet)
