"""The reasoner with the power switches' temperatures: only when the dictionary is built with
them (``switch_temperatures: true``); then their rises over the power stage enter the healthy
model's cells and the fault signatures, a large SMPS low-side Ron is seen where the bus
channels alone barely see it, and a record without them is flagged, not a crash."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.ema.params import (
    SWITCH_CHANNELS,
    ActuatorParams,
    default_actuator_path,
    load_actuator,
)
from mapr_daemon.reasoner.diagnosis import classifier
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary, DictionarySpec
from mapr_daemon.reasoner.diagnosis.features import (
    EXTENDED_SIGNALS,
    SECTOR_SIGNALS,
    SWITCH_SIGNALS,
    derived_signals,
    missing_sources,
    reasoner_signals,
)
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training import dictionary_build
from mapr_daemon.reasoner.training.corpus import Runs, simulate_bit

SPEC = DictionarySpec(
    pressures_pa=(0.0, 1250.0, 2500.0), nominal_per_pressure=4,
    severities=(0.25, 0.5, 0.75, 1.0), kinds=("smps_ron_low", "smps_ron_high", "esr"),
    shorts=("A_high",), opens=("A_high",), seeds_per_point=2, healthy_runs=200,
    calibration_runs=60, record_pool=3, subspace_dims=8, knots=(0.0, 0.5, 1.0), envelope=True,
    ground_share=0.2, detection_map_runs=0, fault_calibration_runs=0)
"""A small envelope dictionary (about 400 runs): the bus voltage over 22-29 V hides the
low-side Ron in the bus channels."""
N = 8
CONDITION = (1500.0, 25.0, 28.6)
"""Dynamic pressure, ambient, bus: a high bus, where the converter regulates with the low
side on for ~16 % of each period (at a low bus it sits at its duty limit: 5 %)."""


def test_switch_signals_are_the_rises_over_the_stage_and_only_asked_for() -> None:
    channels = {"stage_temperature_c": np.array([[30.0, 31.0]]),
                "smps_low_side_temperature_c": np.array([[30.5, 32.0]])}
    out = derived_signals(channels, None)
    np.testing.assert_allclose(out["smps_low_side_rise_k"], [[0.5, 1.0]])
    assert "smps_high_side_rise_k" not in out
    plant = ("commutation_sector", "inverter_duty", *SWITCH_CHANNELS)
    assert reasoner_signals(plant) == (*EXTENDED_SIGNALS, *SECTOR_SIGNALS)
    assert reasoner_signals(plant, True) == (*EXTENDED_SIGNALS, *SECTOR_SIGNALS,
                                             *SWITCH_SIGNALS)
    assert missing_sources((*EXTENDED_SIGNALS, *SWITCH_SIGNALS), ("stage_temperature_c",
                                                                  *SWITCH_CHANNELS)) == []
    assert missing_sources((*EXTENDED_SIGNALS, *SWITCH_SIGNALS), ("stage_temperature_c",)) \
        == list(SWITCH_CHANNELS)
    assert missing_sources(EXTENDED_SIGNALS, ()) == []


def test_the_spec_key_is_read(tmp_path: Path) -> None:
    path = tmp_path / "spec.yaml"
    path.write_text("switch_temperatures: true\nhealthy_runs: 10\n")
    assert DictionarySpec.load(path).switch_temperatures
    assert not DictionarySpec().switch_temperatures


@pytest.fixture(scope="module")
def built() -> tuple[ActuatorParams, dict[bool, Dictionary], dict[str, Runs]]:
    params = load_actuator(default_actuator_path())
    ds = {sw: dictionary_build.build(params, dataclasses.replace(SPEC, switch_temperatures=sw))
          for sw in (False, True)}
    q, amb, bus = ([c] * N for c in CONDITION)
    runs = {name: simulate_bit(params, [faults] * N, q, [700 + i for i in range(N)],
                               ambient_c=amb, bus_v=bus)
            for name, faults in (("healthy", FaultSet()),
                                 ("ron_low", FaultSet.of([at_severity(params, "smps_ron_low",
                                                                      1.0)])))}
    return params, ds, runs


def _named(d: Dictionary, runs: Runs) -> int:
    m = dictionary_build.run_matrices(runs, d.window_starts, d.window_samples, d.signals)
    decisions = [classifier.decide(d, m[i], CONDITION[0]) for i in range(N)]
    return sum(dec.anomaly and dec.fault == "smps_ron_low" for dec in decisions)


@pytest.mark.slow
def test_the_switch_temperatures_see_a_large_low_side_ron_the_bus_channels_miss(
        built: tuple[ActuatorParams, dict[bool, Dictionary], dict[str, Runs]]) -> None:
    _, ds, runs = built
    assert set(SWITCH_SIGNALS) <= set(ds[True].signals)
    assert not set(SWITCH_SIGNALS) & set(ds[False].signals)
    plain, switch = _named(ds[False], runs["ron_low"]), _named(ds[True], runs["ron_low"])
    assert plain <= 3 and switch >= 6, (plain, switch)
    for d in ds.values():
        m = dictionary_build.run_matrices(runs["healthy"], d.window_starts, d.window_samples,
                                          d.signals)
        assert not any(classifier.decide(d, m[i], CONDITION[0]).anomaly for i in range(N))


@pytest.mark.slow
def test_a_record_without_the_switch_temperatures_is_flagged_not_a_crash(
        built: tuple[ActuatorParams, dict[bool, Dictionary], dict[str, Runs]],
        tmp_path: Path) -> None:
    params, ds, runs = built
    path = tmp_path / "d.npz"
    ds[True].save(path)
    d = Dictionary.load(path)
    assert d.signals == ds[True].signals
    described = subprocess.run([sys.executable, "-m", "mapr_daemon.cli.main", "dictionary",
                                "describe", str(path)], capture_output=True, text=True,
                               timeout=120, check=True).stdout
    assert ("switch temperatures: read (smps_high_side_temperature_c, "
            "smps_low_side_temperature_c, inverter_a_high_temperature_c") in described
    record = {k: v[0] for k, v in runs["healthy"].channels.items()
              if k != "smps_low_side_temperature_c"}
    diagnosis = Reasoner(d, params).diagnose_or_flag(record, runs["healthy"].command_deg,
                                                     CONDITION[0])
    assert diagnosis.anomaly is None and diagnosis.error is not None
    assert diagnosis.error["type"] == "RecordError"
    assert "smps_low_side_temperature_c" in diagnosis.error["message"]
    # the dictionary without them diagnoses the same record as before
    plain = Reasoner(ds[False], params).diagnose_or_flag(record, runs["healthy"].command_deg,
                                                         CONDITION[0])
    assert plain.error is None and plain.anomaly is False
