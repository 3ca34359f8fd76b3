"""Mismatched units (:mod:`mapr_daemon.testbed.mismatch`) and the second actuator file."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.cli.main import main
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.training.corpus import simulate_bit
from mapr_daemon.testbed.mismatch import MAX_EFFICIENCY, TOLERANCES, draw_unit, fleet, twin
from mapr_daemon.testbed.profiles import bit_profile

ELEVATOR_PATH = default_actuator_path().parent / "elevator-uav.yaml"
AILERON = load_actuator(default_actuator_path())
ELEVATOR = load_actuator(ELEVATOR_PATH)


def flat(params: ActuatorParams) -> dict[str, float]:
    """Every numeric parameter as ``section.key`` (sensors as one comparable item)."""
    out: dict[str, float] = {}
    for section in dataclasses.fields(params):
        block = getattr(params, section.name)
        if section.name in ("name", "sensors"):
            continue
        for f in dataclasses.fields(block):
            out[f"{section.name}.{f.name}"] = getattr(block, f.name)
    return out


def test_a_unit_is_reproducible_from_its_seed() -> None:
    a, b = draw_unit(ELEVATOR, 123), draw_unit(ELEVATOR, 123)
    assert a.params == b.params and a.form == b.form and a.factors == b.factors
    c = draw_unit(ELEVATOR, 124)
    assert c.params != a.params and c.form != a.form
    units = fleet(AILERON, 5, seed=9)
    assert len({u.seed for u in units}) == 5
    again = draw_unit(AILERON, units[3].seed)
    assert again.params == units[3].params and again.form == units[3].form
    assert [u.seed for u in fleet(AILERON, 5, seed=9)] == [u.seed for u in units]


@pytest.mark.parametrize("datasheet", [AILERON, ELEVATOR], ids=["aileron", "elevator"])
def test_drawn_parameters_lie_within_the_stated_tolerances(datasheet: ActuatorParams) -> None:
    nominal = flat(datasheet)
    moved = {t.path: 0 for t in TOLERANCES}
    for seed in range(60):
        unit = draw_unit(datasheet, seed)
        drawn = flat(unit.params)
        for tol in TOLERANCES:
            ratio = drawn[tol.path] / nominal[tol.path]
            low, high = 1.0 - tol.minus, 1.0 + tol.plus
            if tol.path == "gear.efficiency":
                high = min(high, MAX_EFFICIENCY / nominal[tol.path])
            assert low - 1e-12 <= ratio <= high + 1e-12, (seed, tol.path, ratio)
            assert unit.factors[tol.path] == pytest.approx(ratio, rel=1e-12)
            moved[tol.path] += ratio != 1.0
        untouched = set(nominal) - {t.path for t in TOLERANCES}
        assert all(drawn[k] == nominal[k] for k in untouched)
        assert unit.params.sensors == datasheet.sensors
    assert all(count == 60 for count in moved.values())


def test_drawn_forms_span_the_stated_departures() -> None:
    forms = [draw_unit(AILERON, seed).form for seed in range(60)]
    stiction = [f.breakaway_ratio for f in forms if f.breakaway_ratio]
    assert 15 < len(stiction) < 45 and all(1.2 <= r <= 2.5 for r in stiction)
    assert 0 < sum(f.voltage_mode for f in forms) < 30
    assert {f.current_loop_hz for f in forms} == {0.0, 10e3, 20e3}
    assert all(abs(f.hall_offset_deg) <= 6.0 and 0.5 <= f.housekeeping_w <= 3.0 for f in forms)
    for f in forms:
        assert all(abs(g - 1.0) <= 0.01 for _, g in f.sensor_gain)
        lsb = {c: 2 * s.full_scale / 2**s.bits for c, s in AILERON.sensors.channels.items()}
        assert all(abs(o) <= 3 * lsb[c] + 1e-12 for c, o in f.sensor_offset)


@pytest.mark.parametrize("q", [0.0, ELEVATOR.envelope.max_dynamic_pressure_pa])
def test_the_second_actuator_flies_the_bit_and_holds_its_command(q: float) -> None:
    """The elevator file as it stands and three of its drawn units, at ground and max q."""
    prof = bit_profile(ELEVATOR.sensors.sample_rate_hz, "ground")
    specs = [RunSpec(ELEVATOR, seed=1)] + [u.spec(seed=2) for u in fleet(ELEVATOR, 3, seed=5)]
    block = EmaBatch(specs, powered=False).advance(prof.n_samples, prof.command_deg[None], q)
    pos = block.truth["position_true_deg"]
    rate = ELEVATOR.sensors.sample_rate_hz
    reached = round((prof.corners_s[1] + 0.15) * rate)
    end_of_hold = round(prof.corners_s[2] * rate)
    assert np.abs(pos[0, end_of_hold - 200:end_of_hold] - 20.0).max() < 0.05
    assert np.abs(pos[:, reached:end_of_hold] - 20.0).max() < 2.0
    assert np.abs(pos[:, end_of_hold - 100:end_of_hold] - 20.0).max() < 0.3
    assert np.abs(pos[:, -100:]).max() < 0.3
    assert np.abs(block.channels["dc_bus_voltage_v"][:, 100:] - 24.0).max() < 1.0


def test_simulate_bit_flies_the_units_runspecs() -> None:
    unit = draw_unit(ELEVATOR, 11)
    unit = dataclasses.replace(unit, form=dataclasses.replace(unit.form, housekeeping_w=3.0))
    specs = [RunSpec(ELEVATOR, seed=3, ambient_c=20.0),
             unit.spec(seed=3, ambient_c=20.0),
             unit.spec(FaultSet.of([Fault("esr", 0.8)]), seed=4, bus_v=24.0)]
    runs = simulate_bit(ELEVATOR, [], [0.0, 0.0, 2000.0], [], specs=specs)
    assert runs.labels == ("healthy", "healthy", "esr=0.8")
    rest = runs.channels["dc_link_current_a"][:, :300].mean(axis=1)
    assert rest[1] - rest[0] > 0.1  # the unit's housekeeping load
    ripple = runs.channels["ripple_rms_v"].mean(axis=1)
    assert ripple[2] > 2 * ripple[1]  # the third spec's ESR fault
    with pytest.raises(ConfigError):
        simulate_bit(ELEVATOR, [FaultSet()], [0.0], [1], specs=specs[:1])


def test_a_twin_flies_exactly_as_the_data_sheet_does() -> None:
    """The bench's ceiling (``bench/units.py --twins``) is only a ceiling if a twin's run is
    the data sheet's own, sample for sample, while a drawn unit's is not."""
    unit = twin(AILERON, 7)
    assert flat(unit.params) == flat(AILERON) and unit.form == ModelForm() and not unit.factors
    specs = [RunSpec(AILERON, seed=3, ambient_c=-5.0, bus_v=25.0),
             unit.spec(seed=3, ambient_c=-5.0, bus_v=25.0),
             draw_unit(AILERON, 7).spec(seed=3, ambient_c=-5.0, bus_v=25.0)]
    runs = simulate_bit(AILERON, [], [800.0] * 3, [], specs=specs)
    for name, v in runs.channels.items():
        assert np.array_equal(v[0], v[1]), name
    assert not np.array_equal(runs.channels["dc_link_current_a"][0],
                              runs.channels["dc_link_current_a"][2])


def test_mapr_simulate_unit_records_the_units_truth(tmp_path: Path) -> None:
    out = tmp_path / "u.npz"
    args = ["simulate", "--actuator", str(ELEVATOR_PATH), "--unit", "17", "--pressure", "0",
            "-o", str(out)]
    assert main(args) == 0
    with np.load(out, allow_pickle=False) as d:
        meta = json.loads(str(d["meta_json"]))
        recorded = d["ch_dc_link_current_a"].copy()
    unit = draw_unit(ELEVATOR, 17)
    assert meta["unit"]["seed"] == 17 and meta["unit"]["datasheet"] == "elevator-uav"
    assert meta["unit"]["params"]["motor.resistance_ohm"] == unit.params.motor.resistance_ohm
    assert ModelForm.from_description(meta["unit"]["form"]) == unit.form
    with pytest.raises(ConfigError):
        ModelForm.from_description({**meta["unit"]["form"], "gremlins": 1.0})
    plain = tmp_path / "p.npz"
    assert main(args[:3] + args[5:-1] + [str(plain)]) == 0
    with np.load(plain, allow_pickle=False) as d:
        assert not np.array_equal(d["ch_dc_link_current_a"], recorded)
        assert "unit" not in json.loads(str(d["meta_json"]))
