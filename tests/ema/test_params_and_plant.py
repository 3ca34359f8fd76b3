"""Actuator file loading (errors name file:line: field) and the plant's stepping contract."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import Fault, FaultSet, at_severity, parse_fault, range_end
from mapr_daemon.ema.params import default_actuator_path, load_actuator, parse_actuator
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.ema.run import run_batch
from mapr_daemon.errors import ConfigError
from mapr_daemon.testbed.profiles import bit_profile

TEXT = default_actuator_path().read_text()


def test_shipped_file_has_table1_nominals() -> None:
    p = load_actuator(default_actuator_path())
    assert p.smps.capacitance_f == 288e-6 and p.smps.esr_ohm == 0.05
    assert p.smps.ron_high_ohm == p.smps.ron_low_ohm == 0.2
    assert p.inverter.ron_a_high_ohm == 0.036
    assert range_end(p, "capacitance") == 0.0 and range_end(p, "esr") == pytest.approx(1.0)
    assert range_end(p, "smps_ron_low") == pytest.approx(2.0)
    assert range_end(p, "inverter_ron_a_high") == pytest.approx(0.36)


def test_bad_value_names_file_line_and_field(tmp_path: Path) -> None:
    bad = TEXT.replace("esr_ohm: 0.05", "esr_ohm: fifty")
    f = tmp_path / "bad.yaml"
    f.write_text(bad)
    line = next(k for k, s in enumerate(bad.splitlines(), 1) if "esr_ohm" in s)
    with pytest.raises(ConfigError) as info:
        load_actuator(f)
    assert str(info.value).startswith(f"{f}:{line}: smps.esr_ohm: ")


def test_unknown_and_missing_keys_rejected() -> None:
    with pytest.raises(ConfigError, match=r"smps.esr_ohms: unknown key"):
        parse_actuator(TEXT.replace("esr_ohm:", "esr_ohms:"))
    with pytest.raises(ConfigError, match=r"gear.ratio: missing key"):
        parse_actuator(TEXT.replace("  ratio: 40.0", ""))


def test_the_bit_section_is_required_and_checked() -> None:
    assert load_actuator(default_actuator_path()).bit.amplitude_deg == 20.0
    with pytest.raises(ConfigError, match=r"bit.hold_s: missing key"):
        parse_actuator(TEXT.replace("  hold_s: 0.6", ""))
    with pytest.raises(ConfigError, match=r"bit.ramp_s: must be > 0"):
        parse_actuator(TEXT.replace("  ramp_s: 0.03", "  ramp_s: 0"))
    with pytest.raises(ConfigError, match=r"bit.amplitude_deg: must be below surface.travel"):
        parse_actuator(TEXT.replace("  amplitude_deg: 20.0", "  amplitude_deg: 26.0"))


def test_the_bit_profile_follows_the_actuator_file() -> None:
    from mapr_daemon.ema.bit import bit_profile

    bit = load_actuator(default_actuator_path()).bit
    prof = bit_profile(2000.0, "ground", bit)
    assert prof.corners_s == pytest.approx((0.2, 0.23, 0.83, 0.86))
    assert prof.n_samples == 2920 and prof.command_deg.max() == 20.0
    slower = bit_profile(2000.0, "ground", dataclasses.replace(bit, ramp_s=0.06))
    assert slower.corners_s[1] == pytest.approx(0.26) and slower.n_samples == 3040


def test_fault_text_forms() -> None:
    p = load_actuator(default_actuator_path())
    assert parse_fault("esr=0.5", p) == Fault("esr", 0.5)
    assert parse_fault("short=B_low", p) == Fault("short", switch="B_low")
    assert parse_fault("smps_ron_high@0.5", p).value == pytest.approx(1.1)
    assert at_severity(p, "capacitance", 1.0).value == 0.0
    with pytest.raises(ConfigError):
        parse_fault("short=D_high", p)
    with pytest.raises(ConfigError):
        FaultSet.of([Fault("short", switch="A_low"), Fault("open", switch="A_low")])


def test_chunking_does_not_change_the_run() -> None:
    p = load_actuator(default_actuator_path())
    spec = RunSpec(p, FaultSet.of([Fault("esr", 0.3)]), seed=3)
    a, b = EmaBatch([spec]), EmaBatch([spec])
    cmd = np.linspace(0, 8, 40)
    whole = a.advance(40, cmd, 900.0)
    parts = [b.advance(10, cmd[k:k + 10], 900.0) for k in range(0, 40, 10)]
    for name, values in whole.channels.items():
        np.testing.assert_array_equal(values, np.concatenate([x.channels[name] for x in parts], 1))
    assert parts[-1].time_s[-1] == pytest.approx(40 * a.sample_period_s)


def test_batch_runs_are_independent_of_their_neighbours() -> None:
    p = load_actuator(default_actuator_path())
    spec = RunSpec(p, seed=11)
    alone = EmaBatch([spec]).advance(30, 5.0, 500.0)
    shared = EmaBatch([RunSpec(p, FaultSet.of([Fault("friction", 4.0)]), 2), spec]).advance(
        30, 5.0, 500.0)
    np.testing.assert_allclose(shared.channels["position_deg"][1],
                               alone.channels["position_deg"][0])


def test_hinge_moment_opposes_deflection_and_costs_current() -> None:
    p = load_actuator(default_actuator_path())
    plant = EmaBatch([RunSpec(p, seed=1), RunSpec(p, seed=1)])
    block = plant.advance(600, 10.0, np.array([0.0, 2000.0]))
    hinge = block.truth["hinge_moment_nm"][:, -1]
    assert hinge[0] == 0.0 and hinge[1] < -1.0  # restoring, N m scale
    iq = block.truth["torque_current_a"][:, -100:].mean(axis=1)
    assert iq[1] > iq[0] + 0.3  # holding against the air load needs current
    assert abs(block.channels["position_deg"][1, -1] - 10.0) < 0.5


def test_aircraft_bus_stays_in_mil_std_704_band() -> None:
    p = load_actuator(default_actuator_path())
    plant = EmaBatch([RunSpec(p, seed=s) for s in range(20)])
    block = plant.advance(100)
    vin = block.truth["aircraft_bus_v"]
    assert vin.min() >= 22.0 and vin.max() <= 29.0
    assert np.ptp(vin[:, 0]) > 0.3  # flights differ


def test_run_batch_chunk_as_long_as_the_batch_keeps_the_shared_profile() -> None:
    """A chunk of the profile as long as the batch is still the profile for every run, not
    one held value per run (``advance`` reads a 1-D input of length ``n_runs`` as per-run)."""
    p = load_actuator(default_actuator_path())
    prof = bit_profile(p.sensors.sample_rate_hz, "ground")
    specs = [RunSpec(p, seed=s) for s in range(3)]
    res = run_batch(specs, prof, chunk=3)
    for r in range(3):
        np.testing.assert_allclose(res.truth["command_deg"][r], prof.command_deg)
        np.testing.assert_allclose(res.truth["dynamic_pressure_pa"][r], prof.dynamic_pressure_pa)
