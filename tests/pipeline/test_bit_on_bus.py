"""The built-in test as the bus carries it: the flight control computer requests it, the EMA
runs its stored BIT motion at its own sample rate, and the daemon's BIT watcher rebuilds
exactly the samples the EMA took — so a healthy bus-flown BIT scores like the dictionary's
own healthy BITs, with no threshold override."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from drivers.backends.loopback import LoopbackMonitor
from mapr_daemon.ema.faults import FaultSet, parse_fault
from mapr_daemon.ema.params import default_actuator_path, load_actuator, with_sample_rate
from mapr_daemon.icd import SignalStream, load_icd
from mapr_daemon.pipeline.bitcut import KEEP_S
from mapr_daemon.pipeline.bitwatch import BitWatch
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.testbed.aircraft import FAST_CHANNELS, POWER_CHANNELS, Aircraft
from mapr_daemon.testbed.profiles import bit_profile, steady_profile

ROOT = Path(__file__).resolve().parents[2]
ICD = load_icd(ROOT / "configs" / "icd" / "ema-testbed.yaml")
RATE = 2000.0
FRAMES = 1020  # 2.04 s of 2 ms minor frames: one BIT, and its result after it ends


def fly(fault: str | None, seed: int) -> tuple[Aircraft, list[object]]:
    params = with_sample_rate(load_actuator(default_actuator_path()), RATE)
    faults = FaultSet() if fault is None else FaultSet.of([parse_fault(fault, params)])
    aircraft = Aircraft(ICD, steady_profile(RATE, "cruise"), params, faults, seed=seed,
                        bit_requests_s=(0.0,))
    aircraft.ema.history_s = 10.0   # keep every sample the EMA took, to compare with the bus
    with LoopbackMonitor(terminals=aircraft.terminals(), schedule=aircraft.schedule(),
                         frames=FRAMES) as monitor:
        return aircraft, list(monitor)


@pytest.fixture(scope="module")
def healthy() -> tuple[Aircraft, list[object]]:
    return fly(None, seed=5)


def test_the_ema_runs_its_bit_when_requested(healthy: tuple[Aircraft, list[object]]) -> None:
    aircraft, records = healthy
    series = SignalStream(ICD).feed(records)
    ema = aircraft.ema
    assert ema.bits_run == 1 and ema.bit_state == "DONE"
    states = series["bit_state"]
    assert states.value[0] == 1 and states.value[-1] == 2, "BIT result: RUNNING, then DONE"
    # The surface followed the stored BIT motion, not the FCC's held zero command.
    profile = bit_profile(RATE)
    start = ema.bit_start
    assert start is not None
    position = ema.history["position_deg"]
    moved = position[start:start + profile.n_samples]
    assert moved.max() > 0.8 * profile.command_deg.max()
    echo = series["command_echo"]
    assert np.abs(echo.value).max() == pytest.approx(profile.command_deg.max(), abs=0.01)


def test_the_watcher_rebuilds_the_emas_own_samples(
        healthy: tuple[Aircraft, list[object]], dictionary: Path) -> None:
    aircraft, records = healthy
    watch = BitWatch(Reasoner(Dictionary.load(dictionary),
                              load_actuator(default_actuator_path())))
    (bit,) = watch.feed(SignalStream(ICD).feed(records))
    assert watch.last_onset is not None and bit.onset_ns == watch.last_onset
    # the request went out in the BIT request message before the BIT's first sample
    requests = SignalStream(ICD).feed(records)["bit_request"]
    assert bit.request_ns == int(requests.t_ns[requests.value == 2][0]) < bit.onset_ns
    record = watch.record(watch.last_onset)
    assert record is not None
    channels, q = record
    start = aircraft.ema.bit_start
    assert start is not None
    n = watch.profile.n_samples
    for plant_name in (*FAST_CHANNELS.values(), *POWER_CHANNELS.values()):
        took = aircraft.ema.history[plant_name][start:start + n]
        # sample for sample, within half the table's 1 mA / 1 mV / 1 mdeg / 0.1 mV step
        np.testing.assert_allclose(channels[plant_name], took, atol=0.00051, err_msg=plant_name)
    # the drive's own state: the sector exactly, the signed duty within the table's lsb
    sector = aircraft.ema.history["commutation_sector"][start:start + n]
    np.testing.assert_array_equal(channels["commutation_sector"], sector)
    assert set(np.unique(sector)) >= {1.0, 2.0, 3.0}, "the BIT turns the motor through sectors"
    duty = aircraft.ema.history["inverter_duty"][start:start + n]
    np.testing.assert_allclose(channels["inverter_duty"], duty, atol=0.000126)
    assert duty.min() < -0.1 and duty.max() > 0.1, "both directions, with their signs"
    assert q == pytest.approx(steady_profile(RATE, "cruise").dynamic_pressure_pa[0], rel=1e-3)


def test_healthy_bus_flown_bits_score_below_the_dictionarys_own_threshold(
        healthy: tuple[Aircraft, list[object]], dictionary: Path) -> None:
    scores = []
    for aircraft_records in (healthy, fly(None, seed=6)):
        watch = BitWatch(Reasoner(Dictionary.load(dictionary),
                                  load_actuator(default_actuator_path())))
        events = [bit.decision for bit in watch.feed(SignalStream(ICD).feed(aircraft_records[1]))]
        assert len(events) == 1
        assert events[0].anomaly is False, events[0].evidence
        scores.append(events[0].evidence["score"])
    opened = fly("open=A_high", seed=5)[1]
    watch = BitWatch(Reasoner(Dictionary.load(dictionary), load_actuator(default_actuator_path())))
    (bit,) = watch.feed(SignalStream(ICD).feed(opened))
    event = bit.decision
    assert event.anomaly is True and event.fault == "open"
    assert event.evidence["score"] > 10 * max(scores)


def test_a_reasoner_failure_costs_the_bit_not_the_watcher(
        healthy: tuple[Aircraft, list[object]], dictionary: Path) -> None:
    """A damaged dictionary (its list of M's columns cut short) makes the reasoner raise: the
    watcher logs it, names it in ``failures`` for the daemon's catalog, and carries on."""
    damaged = Dictionary.load(dictionary)
    damaged.columns = damaged.columns[:3]
    watch = BitWatch(Reasoner(damaged, load_actuator(default_actuator_path())))
    series = SignalStream(ICD).feed(healthy[1])
    assert watch.feed(series) == []
    assert watch.failure_count == 1 and len(watch.failures) == 1
    assert watch.failures[0][0] == watch.last_onset
    assert watch.feed({}) == [] and watch.failures == [], "the failed BIT is not retried"


def test_a_batch_longer_than_the_watchers_memory_keeps_its_bit(
        healthy: tuple[Aircraft, list[object]], dictionary: Path) -> None:
    """A file read in large batches (a fleet task, an API user) hands the watcher several
    seconds of bus at once: the BIT at the batch's start is diagnosed as it is from the
    traffic on its own, not trimmed away with the samples older than the watcher keeps."""
    series = SignalStream(ICD).feed(healthy[1])
    later = 3_000_000_000  # the same traffic again 3 s on, without a BIT request
    long_batch = {}
    for name, s in series.items():
        value = np.zeros_like(s.value) if name == "bit_request" else s.value
        long_batch[name] = dataclasses.replace(
            s, t_ns=np.concatenate([s.t_ns, s.t_ns + later]),
            value=np.concatenate([s.value, value]), raw=np.concatenate([s.raw, s.raw]),
            flags=np.concatenate([s.flags, s.flags]))
    span_s = (long_batch["bit_request"].t_ns[-1] - long_batch["bit_request"].t_ns[0]) / 1e9
    assert span_s > KEEP_S, "the batch spans more than the watcher keeps"

    def watcher() -> BitWatch:
        return BitWatch(Reasoner(Dictionary.load(dictionary),
                                 load_actuator(default_actuator_path())))

    (alone,) = watcher().feed(series)
    (in_long,) = watcher().feed(long_batch)
    assert (in_long.request_ns, in_long.onset_ns) == (alone.request_ns, alone.onset_ns)
    assert in_long.decision.evidence["score"] == alone.decision.evidence["score"]
