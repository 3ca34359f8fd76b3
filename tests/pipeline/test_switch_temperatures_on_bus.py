"""The switch temperatures as an aircraft that has them carries them: the EMA puts them in its
slow block when its table has them there (configs/icd/ema-testbed-switch-temperatures.yaml),
a BIT cut from the bus carries them when the asset's wiring names them, and the wiring is
checked like the rest (a wrong channel is one config error naming file:line)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from drivers.backends.loopback import LoopbackMonitor
from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.params import (
    SWITCH_CHANNELS,
    default_actuator_path,
    load_actuator,
    with_sample_rate,
)
from mapr_daemon.errors import ConfigError
from mapr_daemon.icd import SignalStream, load_icd
from mapr_daemon.icd.yamlsrc import load_text
from mapr_daemon.pipeline import wiring
from mapr_daemon.pipeline.bitcut import BitCutter
from mapr_daemon.service.config import parse
from mapr_daemon.testbed.aircraft import Aircraft
from mapr_daemon.testbed.profiles import steady_profile

ROOT = Path(__file__).resolve().parents[2]
RATE = 2000.0
FRAMES = 1020


def fly(icd_name: str) -> tuple[Aircraft, list[object], object]:
    icd = load_icd(ROOT / "configs" / "icd" / icd_name)
    params = with_sample_rate(load_actuator(default_actuator_path()), RATE)
    aircraft = Aircraft(icd, steady_profile(RATE, "cruise"), params, FaultSet(), seed=7,
                        bit_requests_s=(0.0,))
    aircraft.ema.history_s = 10.0
    with LoopbackMonitor(terminals=aircraft.terminals(), schedule=aircraft.schedule(),
                         frames=FRAMES) as monitor:
        return aircraft, list(monitor), icd


@pytest.fixture(scope="module")
def with_sensors() -> tuple[Aircraft, list[object], object]:
    return fly("ema-testbed-switch-temperatures.yaml")


def test_a_bit_cut_from_the_bus_carries_the_wired_switch_temperatures(
        with_sensors: tuple[Aircraft, list[object], object]) -> None:
    aircraft, records, icd = with_sensors
    params = load_actuator(default_actuator_path())
    series = SignalStream(icd).feed(records)   # type: ignore[arg-type]
    (cut,) = BitCutter(params.bit, RATE, signals=wiring.SWITCH_SIGNALS).feed(series)
    assert cut.missing is None
    start = aircraft.ema.bit_start
    assert start is not None
    for channel in SWITCH_CHANNELS:
        own = aircraft.ema.history[channel][start:start + cut.channels[channel].size]
        # the slow block's 100 Hz readings, interpolated onto the BIT's grid
        assert abs(cut.channels[channel].mean() - own.mean()) < 0.05
        assert np.abs(cut.channels[channel] - own).max() < 1.0
    # the high side sits its switching loss over the sink: the channels are not the stage's
    rise = cut.channels["smps_high_side_temperature_c"] - cut.channels["stage_temperature_c"]
    assert 2.0 < rise.mean() < 4.0
    # the same bus read with the shipped wiring: the same BIT, without them
    (plain,) = BitCutter(params.bit, RATE).feed(series)
    assert not set(SWITCH_CHANNELS) & set(plain.channels)
    for name, values in plain.channels.items():
        np.testing.assert_array_equal(values, cut.channels[name])


def test_an_aircraft_without_them_is_cut_without_them_even_when_wired() -> None:
    _, records, icd = fly("ema-testbed.yaml")
    params = load_actuator(default_actuator_path())
    series = SignalStream(icd).feed(records)   # type: ignore[arg-type]
    (cut,) = BitCutter(params.bit, RATE, signals=wiring.SWITCH_SIGNALS).feed(series)
    assert cut.missing is None
    assert not set(SWITCH_CHANNELS) & set(cut.channels)


def test_a_wrong_switch_channel_in_the_wiring_is_one_error_naming_file_and_line() -> None:
    lines = [f"      {k}: {v}" for k, v in wiring.SWITCH_SIGNALS.items()]
    good = "assets:\n  - name: EMA1\n    signals:\n" + "\n".join(lines) + "\n"
    config = parse(load_text(good, "x.yaml"), "x.yaml")
    assert wiring.switch_channels(config.assets[0].signals) == SWITCH_CHANNELS
    bad = good.replace("smps_low_side_temperature_c", "smps_low_temperature_c")
    line = next(k for k, s in enumerate(bad.splitlines(), 1) if "smps_low_temperature_c" in s)
    with pytest.raises(ConfigError) as caught:
        parse(load_text(bad, "x.yaml"), "x.yaml")
    assert str(caught.value).startswith(
        f"x.yaml:{line}: assets[0].signals.smps_low_side_temperature: "
        "'smps_low_temperature_c' is not a reasoner channel")
