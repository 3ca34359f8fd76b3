"""Model-form options (:mod:`mapr_daemon.ema.form`): each changes the records as its physics says.

The default form's bit-identity with the recorded reference runs is ``test_step.py``'s; here a
default run must also be unchanged by form-carrying neighbours in its batch.
"""

from __future__ import annotations

import numpy as np
import pytest

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.ema.plant import EmaBatch, SensorBlock
from mapr_daemon.errors import ConfigError
from mapr_daemon.testbed.profiles import bit_profile

PARAMS = load_actuator(default_actuator_path())
RATE = PARAMS.sensors.sample_rate_hz
PHASES = ("phase_a_current_a", "phase_b_current_a", "phase_c_current_a")


def fly(forms: list[ModelForm], command: FloatArray | float, q: float,
        n: int | None = None) -> SensorBlock:
    cmd = np.asarray(command, dtype=np.float64)
    n = cmd.size if n is None else n
    plant = EmaBatch([RunSpec(PARAMS, form=f, seed=4, ambient_c=25.0) for f in forms])
    return plant.advance(n, cmd[None] if cmd.ndim else float(cmd), q)


def test_a_default_run_is_unchanged_by_neighbours_with_another_form() -> None:
    cmd = np.linspace(0.0, 8.0, 400)
    alone = fly([ModelForm()], cmd, 1500.0)
    odd = ModelForm(breakaway_ratio=2.0, hall_offset_deg=8.0, housekeeping_w=2.0,
                    voltage_mode=True, current_loop_hz=10e3, position_loop_hz=1e3,
                    sensor_gain=(("dc_link_current_a", 1.01),))
    mixed = fly([odd, ModelForm()], cmd, 1500.0)
    for name, values in {**alone.channels, **alone.truth}.items():
        np.testing.assert_array_equal(values[0], (mixed.channels | mixed.truth)[name][1])


def test_stiction_starts_the_motor_later_and_lags_a_slow_ramp() -> None:
    """1 deg over 0.3 s: the stuck shaft waits for the loop to build the breakaway torque."""
    cmd = np.concatenate([np.linspace(0.0, 1.0, 600), np.full(200, 1.0)])
    block = fly([ModelForm(), ModelForm(breakaway_ratio=2.5, stribeck_speed_rad_s=3.0)], cmd,
                0.0)
    speed = np.abs(block.truth["motor_speed_rad_s"])
    start = (speed > 0.5).argmax(axis=1)
    assert start[1] > start[0] + 20  # > 10 ms later
    lag = cmd[100:600] - block.truth["position_true_deg"][:, 100:600]
    assert lag[1].mean() > 1.5 * lag[0].mean()
    # stuck means stuck: whole samples at exactly zero speed, which smoothed Coulomb never has
    assert (speed[1, 1:] == 0.0).sum() > 20 and (speed[0, 1:] == 0.0).sum() == 0


def test_a_hall_offset_needs_more_phase_current_for_the_torque() -> None:
    prof = bit_profile(RATE, "ground")
    forms = [ModelForm(), ModelForm(hall_offset_deg=15.0), ModelForm(hall_offset_deg=-15.0)]
    block = fly(forms, prof.command_deg, 2500.0)
    rms = np.sqrt(np.mean([block.channels[c] ** 2 for c in PHASES], axis=0))
    per_amp = np.abs(block.truth["motor_torque_nm"]).sum(axis=1) / rms.sum(axis=1)
    assert per_amp[1] < 0.99 * per_amp[0] and per_amp[2] < 0.99 * per_amp[0]
    # the drive reports the sector its (offset) Hall sensors read
    assert not np.array_equal(block.channels["commutation_sector"][0],
                              block.channels["commutation_sector"][1])


def test_a_housekeeping_load_draws_dc_link_and_smps_input_current_at_rest() -> None:
    block = fly([ModelForm(), ModelForm(housekeeping_w=3.0)], 0.0, 0.0, n=400)
    dc = block.channels["dc_link_current_a"][:, 100:].mean(axis=1)
    smps_in = block.channels["smps_input_current_a"][:, 100:].mean(axis=1)
    assert abs(dc[1] - dc[0] - 3.0 / 24.0) < 0.01  # constant power off the 24 V link
    assert 0.8 * 3.0 / 27.5 < smps_in[1] - smps_in[0] < 1.3 * 3.0 / 22.0


def test_sensor_gain_and_offset_errors_are_visible_in_their_channels_only() -> None:
    form = ModelForm(sensor_gain=(("dc_bus_voltage_v", 1.01),),
                     sensor_offset=(("smps_input_voltage_v", 0.2),))
    block = fly([ModelForm(), form], 0.0, 0.0, n=400)
    link = block.channels["dc_bus_voltage_v"].mean(axis=1)
    assert abs(link[1] - 1.01 * link[0]) < 0.01
    vin = block.channels["smps_input_voltage_v"].mean(axis=1)
    assert abs(vin[1] - vin[0] - 0.2) < 0.01
    np.testing.assert_array_equal(block.channels["position_deg"][0],
                                  block.channels["position_deg"][1])


@pytest.mark.parametrize("form", [
    ModelForm(current_loop_hz=10e3, position_loop_hz=1e3),
    ModelForm(voltage_mode=True),
    ModelForm(voltage_mode=True, current_loop_hz=20e3, position_loop_hz=2e3),
], ids=["discrete", "voltage-mode", "voltage-mode-discrete"])
def test_another_control_law_differs_but_tracks_the_bit_command(form: ModelForm) -> None:
    prof = bit_profile(RATE, "ground")
    block = fly([ModelForm(), form], prof.command_deg, 2500.0)
    pos = block.truth["position_true_deg"]
    assert np.abs(pos[1] - pos[0]).max() > 0.05
    end_of_hold = round(prof.corners_s[2] * RATE)
    assert np.abs(pos[1, end_of_hold - 100:end_of_hold] - 20.0).max() < 0.2
    assert np.abs(pos[1, -100:]).max() < 0.2


def test_discrete_loop_rates_round_to_whole_steps_and_bad_forms_are_config_errors() -> None:
    assert ModelForm().loop_steps(25e-6) == (1, 1)
    assert ModelForm(current_loop_hz=10e3, position_loop_hz=1e3).loop_steps(25e-6) == (4, 40)
    with pytest.raises(ConfigError):
        ModelForm(current_loop_hz=1e6).loop_steps(25e-6)
    for bad in ({"breakaway_ratio": 0.5}, {"hall_offset_deg": 31.0},
                {"housekeeping_variation": 2.0}, {"sensor_gain": (("no_such", 1.0),)},
                {"sensor_gain": (("dc_bus_voltage_v", 0.0),)}, {"stribeck_speed_rad_s": 0.0}):
        with pytest.raises(ConfigError):
            ModelForm(**bad)  # type: ignore[arg-type]
