"""The drive's own channels: commutation sector and applied PWM duty.

``commutation_sector`` is the Hall sector (1-6) at the sample instant; ``inverter_duty`` the
signed duty averaged over the sample period, in whole PWM timer counts. A user reading them
should see the sector step through 1..6 in the direction of motion, the duty's sign follow
the drive direction, and duty x DC bus equal the voltage the windings need.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.ema.params import CONTROLLER_CHANNELS, default_actuator_path, load_actuator
from mapr_daemon.ema.plant import EmaBatch, SensorBlock

PARAMS = load_actuator(default_actuator_path())
RATE = PARAMS.sensors.sample_rate_hz
DUTY_LSB = RATE / (PARAMS.inverter.pwm_counter_period * PARAMS.inverter.pwm_frequency_hz)


HEALTHY = FaultSet()


def move(faults: FaultSet = HEALTHY) -> SensorBlock:
    """Up to +15 deg in 0.1 s, hold 0.5 s against the cruise air load, back to -5 deg, hold."""
    up = np.linspace(0.0, 15.0, 200)
    down = np.linspace(15.0, -5.0, 200)
    cmd = np.r_[up, np.full(1000, 15.0), down, np.full(400, -5.0)]
    plant = EmaBatch([RunSpec(PARAMS, faults, seed=4)])
    return plant.advance(cmd.size, cmd, 1600.0)


def sector_of(position_deg: np.ndarray) -> np.ndarray:
    theta_e = np.radians(position_deg) * PARAMS.gear.ratio * PARAMS.motor.pole_pairs
    return np.floor((theta_e - math.pi / 6) / (math.pi / 3)).astype(np.int64) % 6 + 1


def test_sector_steps_through_one_to_six_with_the_motion() -> None:
    block = move()
    sec = block.channels["commutation_sector"][0]
    assert set(np.unique(sec)) == {1.0, 2.0, 3.0, 4.0, 5.0, 6.0}
    assert np.all(sec == np.round(sec))
    changes = np.flatnonzero(np.diff(sec))
    steps = (np.diff(sec)[changes] % 6).astype(int)
    up, down = changes < 220, (changes > 1200) & (changes < 1420)  # the ramps
    # one or two sectors per sample when the motor is fast, never backwards on a ramp
    assert steps[up].size > 20 and set(steps[up]) <= {1, 2}
    assert steps[down].size > 20 and set(steps[down]) <= {4, 5}
    # and it is the sector of the rotor angle (the true position, a sample mean, agrees
    # except when the rotor crosses a sector edge within the sample)
    agree = sector_of(block.truth["position_true_deg"][0]) == sec
    assert agree.mean() > 0.8


def test_duty_is_signed_counted_and_drives_the_winding_voltage() -> None:
    block = move()
    duty = block.channels["inverter_duty"][0]
    counts = duty / DUTY_LSB
    np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)
    assert np.abs(duty).max() <= 0.98 + DUTY_LSB  # the drive's duty limit
    # its sign is the drive direction: the sign of the voltage the windings need
    # (resistive drop plus back-EMF), so decelerating from a fast move still drives forward
    r_loop = 2.0 * (block.truth["winding_resistance_ohm"][0] + PARAMS.inverter.ron_ohm)
    emf = 2.0 * PARAMS.motor.back_emf_v_s_per_rad * block.truth["motor_speed_rad_s"][0]
    needed = r_loop * block.truth["torque_current_a"][0] + emf
    clear = np.abs(needed) > 0.2
    assert clear.sum() > 500
    assert np.mean(np.sign(duty[clear]) == np.sign(needed[clear])) > 0.97
    # holding at +15 deg against the air load (no speed): duty * Vdc = R_loop * i_q
    hold = slice(900, 1200)
    applied = (duty * block.channels["dc_bus_voltage_v"][0])[hold].mean()
    needed = needed[hold].mean()
    assert applied == pytest.approx(needed, rel=0.03)


def test_controller_channels_carry_no_sensor_noise() -> None:
    runs = [RunSpec(PARAMS, seed=1), RunSpec(PARAMS, seed=2)]
    block = EmaBatch(runs).advance(200, 0.0, 0.0)
    for name in CONTROLLER_CHANNELS:
        assert np.ptp(block.channels[name]) == 0.0, name  # idle: no noise on these
    assert block.channels["inverter_duty"][0, 0] == 0.0
    assert np.ptp(block.channels["dc_link_current_a"]) > 0.0  # the sensors do have noise


def test_an_open_a_high_switch_leaves_the_drive_pushing_harder_in_its_sectors() -> None:
    healthy = move()
    faulted = move(FaultSet.of([Fault("open", switch="A_high")]))
    def a_high_duty(block: SensorBlock) -> float:
        sec = block.channels["commutation_sector"][0]
        duty = block.channels["inverter_duty"][0]
        a_high = ((duty > 0) & np.isin(sec, (1, 2))) | ((duty < 0) & np.isin(sec, (4, 5)))
        return float(np.abs(duty[a_high]).mean())
    assert a_high_duty(faulted) > a_high_duty(healthy) + 0.1
