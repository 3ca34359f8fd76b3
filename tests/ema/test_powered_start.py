"""A powered run starts in the powered steady state; an unpowered one with the soft start.

``EmaBatch(powered=True)`` stands for an actuator whose supply has been on for a long time:
the DC bus must sit at its regulated 24 V from the first sample, with no start-up transient.
``powered=False`` keeps the soft start from t = 0 (the paper's capacitance observation is
about that start-up).
"""

from __future__ import annotations

import numpy as np

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.ema.plant import EmaBatch

PARAMS = load_actuator(default_actuator_path())
SETTLED = slice(100, 200)
"""Samples 50-100 ms into an idle run: long after any start-up transient."""


def tolerance(name: str) -> float:
    """Four noise sigmas plus two quantisation steps of the channel."""
    spec = PARAMS.sensors.channels[name]
    return 4.0 * spec.noise_rms + 2.0 * (2.0 * spec.full_scale / 2.0**spec.bits)


def test_first_samples_of_a_powered_run_sit_at_the_steady_values() -> None:
    runs = [RunSpec(PARAMS, seed=s) for s in (1, 2, 3)]
    block = EmaBatch(runs, powered=True).advance(200, 0.0, 1200.0)
    # (the SMPS input voltage is the aircraft bus, which has its own ripple and drift)
    for name in ("dc_bus_voltage_v", "dc_link_current_a", "smps_input_current_a",
                 "ripple_rms_v", "phase_a_current_a", "position_deg"):
        x = block.channels[name]
        steady = x[:, SETTLED].mean(axis=1, keepdims=True)
        worst = np.abs(x[:, :10] - steady).max()
        assert worst <= tolerance(name), f"{name}: first samples {worst:.4g} off steady"
    assert np.abs(block.channels["dc_bus_voltage_v"][:, 0] - 24.0).max() <= tolerance(
        "dc_bus_voltage_v")
    # the averaged SMPS itself: no inductor current, duty at Vref/Vin from the first step
    assert np.abs(block.truth["inductor_current_a"][:, :10]).max() < 1e-9
    duty_expected = 24.0 / block.truth["aircraft_bus_v"][:, :10]
    np.testing.assert_allclose(block.truth["smps_duty"][:, :10], duty_expected, rtol=1e-3)


def test_unpowered_run_still_starts_with_the_soft_start() -> None:
    block = EmaBatch([RunSpec(PARAMS, seed=1)], powered=False).advance(60, 0.0, 0.0)
    bus = block.channels["dc_bus_voltage_v"][0]
    soft_start = PARAMS.smps.soft_start_s
    rate = PARAMS.sensors.sample_rate_hz
    assert bus[0] < 2.0  # starts from an empty capacitor
    mid = int(0.5 * soft_start * rate)
    assert 8.0 < bus[mid] < 16.0  # half way up the ramp at half the soft-start time
    assert abs(bus[-1] - 24.0) <= tolerance("dc_bus_voltage_v")
