"""Two EMAs of different types on one loopback bus: the aileron (RT 5, 2 kHz) and the elevator
(RT 7, 1 kHz) of configs/icd/ema-testbed-two-ema.yaml, each with its own fault, seed and BIT
requests, each decoded and each BIT found with its own asset's wiring."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from drivers.backends.loopback import LoopbackMonitor
from drivers.mil1553.record import MonitorRecord
from mapr_daemon.ema.faults import FaultSet, parse_fault
from mapr_daemon.ema.params import ActuatorParams, load_actuator, with_sample_rate
from mapr_daemon.icd import SignalStream, load_icd
from mapr_daemon.pipeline import wiring
from mapr_daemon.pipeline.bitwatch import BitWatch
from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training import dictionary_build
from mapr_daemon.service.config import load_config
from mapr_daemon.testbed.aircraft import FAST_CHANNELS, POWER_CHANNELS, Aircraft
from mapr_daemon.testbed.config import parse_section
from mapr_daemon.testbed.profiles import steady_profile

ROOT = Path(__file__).resolve().parents[2]
ICD = load_icd(ROOT / "configs" / "icd" / "ema-testbed-two-ema.yaml")
AILERON = with_sample_rate(load_actuator(ROOT / "configs/actuators/aileron-uav.yaml"), 2000.0)
ELEVATOR = with_sample_rate(load_actuator(ROOT / "configs/actuators/elevator-uav.yaml"), 1000.0)
FRAMES = 1020   # 2.04 s: one BIT of each EMA (1.46 s) and its end


def fly(elevator_fault: str | None, *, frames: int = FRAMES
        ) -> tuple[Aircraft, list[MonitorRecord]]:
    faults = FaultSet() if elevator_fault is None else \
        FaultSet.of([parse_fault(elevator_fault, ELEVATOR)])
    aircraft = Aircraft(ICD, steady_profile(2000.0, "cruise"), AILERON, seed=3,
                        bit_requests_s=(0.0,))
    aircraft.add_ema(7, ELEVATOR, faults, seed=4, bit_requests_s=(0.0,))
    for ema in aircraft.emas:
        ema.history_s = 10.0   # keep every sample, to compare with the bus
    with LoopbackMonitor(terminals=aircraft.terminals(), schedule=aircraft.schedule(),
                         frames=frames) as monitor:
        return aircraft, list(monitor)


@pytest.fixture(scope="module")
def healthy() -> tuple[Aircraft, list[MonitorRecord]]:
    return fly(None)


def tiny_dictionary(params: ActuatorParams) -> Reasoner:
    """A small dictionary (healthy and ESR) at the actuator's own sample rate."""
    spec = DictionarySpec(pressures_pa=(1600.0,), nominal_per_pressure=2,
                          severities=(0.5, 1.0), kinds=("esr",), shorts=(), opens=(),
                          healthy_runs=48, calibration_runs=12, envelope=True,
                          ground_share=0.0, threshold_margin=1.5)
    return Reasoner(dictionary_build.build(params, spec), params)


def test_both_emas_stream_their_own_samples_on_one_bus(
        healthy: tuple[Aircraft, list[MonitorRecord]]) -> None:
    aircraft, records = healthy
    assert {r.rt for r in records} == {5, 6, 7}
    series = SignalStream(ICD).feed(records)
    for ema, prefix, rate in ((aircraft.emas[0], "", 2000.0),
                              (aircraft.emas[1], "elevator_", 1000.0)):
        assert ema.bits_run == 1 and ema.rate_hz == rate
        for icd_name, plant_name in (*FAST_CHANNELS.items(), *POWER_CHANNELS.items()):
            s = series[prefix + icd_name]
            index = np.round(s.t_ns * rate / 1e9).astype(int) - 1   # sample k at (k+1)/rate
            later = index >= 8   # the first block is padded: the plant had not run yet
            took = ema.history[plant_name][index[later]]
            # sample for sample, at the right time, within half the table's step
            np.testing.assert_allclose(s.value.reshape(-1)[later], took, atol=0.00051,
                                       err_msg=prefix + icd_name)
    # two different actuators: the same BIT motion draws different currents
    a, e = series["phase_current_a"], series["elevator_phase_current_a"]
    assert np.abs(a.value).max() != pytest.approx(np.abs(e.value).max(), rel=0.05)


def test_a_fault_on_the_elevator_changes_only_the_elevators_signals(
        healthy: tuple[Aircraft, list[MonitorRecord]]) -> None:
    before = SignalStream(ICD).feed(healthy[1])
    after = SignalStream(ICD).feed(fly("esr=0.6")[1])
    for name in ("phase_current_a", "dc_bus_voltage", "smps_ripple_rms", "surface_position"):
        np.testing.assert_array_equal(after[name].value, before[name].value, err_msg=name)
    ripple = "elevator_smps_ripple_rms"
    assert after[ripple].value.mean() > 2 * before[ripple].value.mean()


def test_each_bit_is_found_with_its_assets_wiring(
        healthy: tuple[Aircraft, list[MonitorRecord]]) -> None:
    series = SignalStream(ICD).feed(healthy[1])
    aileron = BitWatch(tiny_dictionary(AILERON), signals=wiring.DEFAULT_SIGNALS)
    elevator = BitWatch(tiny_dictionary(ELEVATOR), signals=wiring.TWO_EMA_ELEVATOR_SIGNALS)
    (a_bit,) = aileron.feed(series)
    (e_bit,) = elevator.feed(series)
    requests = {name: series[name] for name in ("bit_request", "elevator_bit_request")}
    assert a_bit.request_ns == int(requests["bit_request"].t_ns[
        requests["bit_request"].value == 2][0])
    assert e_bit.request_ns == int(requests["elevator_bit_request"].t_ns[
        requests["elevator_bit_request"].value == 2][0])
    assert a_bit.request_ns != e_bit.request_ns
    for bit, watch in ((a_bit, aileron), (e_bit, elevator)):
        assert bit.request_ns < bit.onset_ns < bit.request_ns + 10_000_000
        record = watch.record(bit.onset_ns)   # every channel on the bus for the whole BIT
        assert record is not None and record[0]["phase_a_current_a"].size == \
            watch.profile.n_samples
        assert bit.decision.evidence["bit_bus_time_s"] == round(bit.onset_ns / 1e9, 6)


def test_the_example_config_flies_two_emas_and_old_configs_one(tmp_path: Path) -> None:
    text = (ROOT / "configs" / "mapr-two-ema.yaml").read_text(encoding="utf-8")
    # assets[].dictionary is parsed by the daemon's multi-asset config, not by this branch
    text = "\n".join(line for line in text.splitlines()
                     if not line.strip().startswith("dictionary:"))
    copy = tmp_path / "configs" / "mapr-two-ema.yaml"
    copy.parent.mkdir()
    copy.write_text(text, encoding="utf-8")
    for sub in ("icd", "actuators"):
        (copy.parent / sub).symlink_to(ROOT / "configs" / sub)
    config = load_config(copy)
    flown = parse_section(config.testbed, config.source).flown(config.assets)
    assert [(a.name, a.rt, Path(a.actuator).name, a.fault) for a in flown] == [
        ("EMA1", 5, "aileron-uav.yaml", None), ("EMA2", 7, "elevator-uav.yaml", "esr=0.6")]
    assert [a.signals for a in config.assets] == [wiring.DEFAULT_SIGNALS,
                                                  wiring.TWO_EMA_ELEVATOR_SIGNALS]
    single = load_config(ROOT / "configs" / "mapr.yaml")
    (one,) = parse_section(single.testbed, single.source).flown(single.assets)
    assert (one.name, one.rt, one.fault, one.seed) == ("EMA1", 5, None, 1)
