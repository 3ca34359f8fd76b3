"""The per-switch temperature channels: optional in the actuator file, invisible to every
channel that existed before them, and warmed by their own switch's loss.

``existing_channels.json`` holds SHA-256 digests of the pre-existing channels of three runs
(healthy, an SMPS low-side Ron fault, a shorted switch through the general bridge legs),
recorded with the plant before the switch temperatures existed::

    PYTHONPATH=<checkout before them> python3 -c "import tests.ema.test_switch_temperatures \\
        as t; t.record()"
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.bit import bit_profile
from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.ema.params import (
    CHANNELS,
    CONTROLLER_CHANNELS,
    default_actuator_path,
    load_actuator,
    parse_actuator,
)
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.errors import ConfigError

DIGESTS = Path(__file__).resolve().parents[1] / "data" / "ema" / "existing_channels.json"
TEXT = default_actuator_path().read_text()
SAMPLES = 1200


def _runs() -> dict[str, object]:
    """Every pre-existing channel and truth signal of the three runs, 1200 BIT samples."""
    params = load_actuator(default_actuator_path())
    faults = (FaultSet(), FaultSet.of([Fault("smps_ron_low", 1.5)]),
              FaultSet.of([Fault("short", switch="A_high")]))
    specs = [RunSpec(params, f, seed=3 + k, ambient_c=10.0 + 20 * k, bus_v=28.0 - k)
             for k, f in enumerate(faults)]
    prof = bit_profile(params.sensors.sample_rate_hz, "ground", params.bit)
    plant = EmaBatch(specs)
    blocks = [plant.advance(n, prof.command_deg[None, k:k + n], 1200.0)
              for k, n in ((0, 700), (700, SAMPLES - 700))]
    out: dict[str, object] = {}
    for name in (*CHANNELS, *CONTROLLER_CHANNELS):
        out[f"ch/{name}"] = np.concatenate([b.channels[name] for b in blocks], axis=1)
    for name in blocks[0].truth:
        out[f"truth/{name}"] = np.concatenate([b.truth[name] for b in blocks], axis=1)
    return out


def digests() -> dict[str, str]:
    """SHA-256 of each signal's float64 bytes (C order)."""
    return {k: hashlib.sha256(np.ascontiguousarray(v, dtype=np.float64).tobytes()).hexdigest()
            for k, v in _runs().items()}


def record() -> None:
    """Write the digests from the current plant (see the module docstring)."""
    DIGESTS.write_text(json.dumps(digests(), indent=1, sort_keys=True) + "\n")


def test_existing_channels_are_bit_identical_to_the_plant_before_switch_temperatures() -> None:
    want = json.loads(DIGESTS.read_text())
    got = digests()
    changed = sorted(k for k in want if got.get(k) != want[k])
    assert not changed, f"changed: {changed}"


def test_a_file_without_the_switches_section_gets_the_documented_defaults() -> None:
    params = parse_actuator(TEXT)
    assert params.switches.smps_thermal_resistance_k_per_w == 3.6
    assert params.switches.inverter_time_constant_s == 0.5


def test_the_switches_section_is_read_and_checked_like_any_other() -> None:
    text = TEXT + ("\nswitches:\n  smps_thermal_resistance_k_per_w: 5.0\n"
                   "  smps_time_constant_s: 1.0\n  inverter_thermal_resistance_k_per_w: 2.0\n"
                   "  inverter_time_constant_s: 0.4\n  sensor_rate_hz: 100.0\n")
    params = parse_actuator(text)
    assert params.switches.smps_thermal_resistance_k_per_w == 5.0
    bad = text.replace("  smps_time_constant_s: 1.0\n", "  smps_time_constant: 1.0\n")
    line = next(k for k, s in enumerate(bad.splitlines(), 1) if "smps_time_constant:" in s)
    with pytest.raises(ConfigError) as info:
        parse_actuator(bad, "a.yaml")
    assert str(info.value).startswith(f"a.yaml:{line}: switches.smps_time_constant: ")


def _sustained(ron_low: float) -> dict[str, float]:
    """3 s of a 3 Hz +-20 deg square command at 28.8 V bus and 2.5 kPa: the SMPS carries
    current in every reversal, at a duty (~0.84) its loop regulates. Means over the last
    second, and the low side's mean conduction loss from the noise-free duty and inductor
    current."""
    params = load_actuator(default_actuator_path())
    rate = params.sensors.sample_rate_hz
    t = np.arange(int(3 * rate)) / rate
    cmd = 20.0 * np.sign(np.sin(2 * np.pi * 3.0 * t))
    spec = RunSpec(params, FaultSet.of([Fault("smps_ron_low", ron_low)]), seed=11,
                   ambient_c=25.0, bus_v=28.8)
    block = EmaBatch([spec]).advance(t.size, cmd[None, :], 2500.0)
    last = slice(-int(rate), None)
    ch, truth = block.channels, block.truth
    duty, i_l = truth["smps_duty"][0, last], truth["inductor_current_a"][0, last]
    return {"low_rise": float((ch["smps_low_side_temperature_c"][0, last]
                               - ch["stage_temperature_c"][0, last]).mean()),
            "low_loss_w": float((ron_low * (1.0 - duty) * i_l**2).mean()),
            **{k: float(ch[k][0, last].mean()) for k in (
                "dc_bus_voltage_v", "dc_link_current_a", "smps_input_current_a")},
            "duty": float(duty.mean())}


def test_the_low_side_switch_warms_with_its_ron_where_the_bus_channels_do_not_move() -> None:
    healthy, faulty = _sustained(0.2), _sustained(2.0)
    assert 0.75 < healthy["duty"] < 0.9
    # the junction's rise over the sink grows with Ron, as its resistance times its loss
    gained = faulty["low_rise"] - healthy["low_rise"]
    assert gained > 0.2
    assert gained == pytest.approx(3.6 * (faulty["low_loss_w"] - healthy["low_loss_w"]),
                                   rel=0.15)
    # ... while the regulated DC link and the load it feeds stay put, and the SMPS input
    # current (where the loss shows on the bus side) moves by under 3 %
    assert abs(faulty["dc_bus_voltage_v"] - healthy["dc_bus_voltage_v"]) < 0.002
    assert abs(faulty["dc_link_current_a"] - healthy["dc_link_current_a"]) < 0.002
    assert abs(faulty["smps_input_current_a"] / healthy["smps_input_current_a"] - 1) < 0.03


def test_switch_channels_follow_the_stage_sensor_and_their_nodes() -> None:
    params = load_actuator(default_actuator_path())
    hot = dataclasses.replace(params, switches=dataclasses.replace(
        params.switches, smps_thermal_resistance_k_per_w=10.0))
    blocks = [EmaBatch([RunSpec(p, seed=2, ambient_c=0.0)]).advance(400, 0.0, 0.0)
              for p in (params, hot)]
    lsb = 2 * params.sensors.channels["stage_temperature_c"].full_scale / 2**12
    for b in blocks:
        values = b.channels["smps_high_side_temperature_c"]
        assert np.allclose(values / lsb, np.round(values / lsb))
    # idle: the high side sits its switching loss times its resistance over the sink
    rise = [float((b.channels["smps_high_side_temperature_c"]
                   - b.channels["stage_temperature_c"]).mean()) for b in blocks]
    p_sw = params.smps.switching_loss_w
    assert rise[0] == pytest.approx(3.6 * p_sw, abs=0.1)
    assert rise[1] == pytest.approx(10.0 * p_sw, abs=0.1)


def test_switch_sensors_integrate_over_their_period_and_hold_in_between() -> None:
    params = load_actuator(default_actuator_path())
    block = EmaBatch([RunSpec(params, seed=5)]).advance(4000, 0.0, 0.0)
    every = round(params.sensors.sample_rate_hz / params.switches.sensor_rate_hz)
    stage = block.channels["stage_temperature_c"][0]
    for name in ("smps_high_side_temperature_c", "smps_low_side_temperature_c"):
        x = block.channels[name][0].reshape(-1, every)
        assert (x == x[:, :1]).all()                      # held within a reading period
        assert len(np.unique(x[:, 0])) > 1                # and read anew (noise) each period
        # a reading averages its period's samples: sqrt(20) less noise than the stage's own
        # 2 kHz samples (what is left is mostly the 0.1 K quantisation)
        assert np.std(np.diff(x[:, 0])) < 0.5 * np.std(np.diff(stage))


def test_an_empty_chunk_first_changes_nothing() -> None:
    params = load_actuator(default_actuator_path())
    plant = EmaBatch([RunSpec(params, seed=9)])
    plant.advance(0, 0.0, 0.0)
    after = plant.advance(60, 0.0, 0.0).channels
    direct = EmaBatch([RunSpec(params, seed=9)]).advance(60, 0.0, 0.0).channels
    for name in direct:
        np.testing.assert_array_equal(after[name], direct[name])
