"""The reasoner over the whole operating envelope: a dictionary built with ``envelope: true``
decides healthy BITs on the ground, in the cold, in the heat and on a low bus without an alarm,
and still names a fault flown at those conditions.

The BITs are the plant's at conditions the dictionary's runs did not have (their own seeds,
temperatures, voltages); the old reasoner alarmed on 19 of 100 healthy ground BITs and on 3 of
5 at -10 C, and called every BIT below 25.8 V of bus inconclusive.
"""

from __future__ import annotations

import numpy as np
import pytest

from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.reasoner.diagnosis import classifier
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary, DictionarySpec
from mapr_daemon.reasoner.training import dictionary_build
from mapr_daemon.reasoner.training.corpus import simulate_bit

SPEC = DictionarySpec(
    pressures_pa=(0.0, 1250.0, 2500.0), nominal_per_pressure=4,
    severities=(0.25, 0.5, 0.75, 1.0), kinds=("esr", "friction"), shorts=("A_high",),
    opens=("A_high",), seeds_per_point=2, healthy_runs=200, calibration_runs=40,
    record_pool=3, subspace_dims=8, knots=(0.0, 0.5, 1.0), envelope=True, ground_share=0.2)

CORNERS = [  # (dynamic pressure Pa, ambient C, bus mean V): the envelope's corners
    (0.0, -38.0, 22.4), (0.0, -10.0, 24.5), (0.0, 68.0, 28.8), (2400.0, -38.0, 28.8),
    (2400.0, 68.0, 22.4), (0.0, 25.0, 27.5), (1200.0, -25.0, 25.5), (600.0, 45.0, 23.2)]


@pytest.fixture(scope="module")
def envelope() -> tuple[ActuatorParams, Dictionary]:
    params = load_actuator(default_actuator_path())
    return params, dictionary_build.build(params, SPEC)


def _decide(params: ActuatorParams, d: Dictionary, faults: FaultSet,
            seed: int) -> list[classifier.Decision]:
    q, amb, bus = (list(col) for col in zip(*CORNERS, strict=True))
    runs = simulate_bit(params, [faults] * len(CORNERS), q,
                        [seed + i for i in range(len(CORNERS))], ambient_c=amb, bus_v=bus)
    m = dictionary_build.run_matrices(runs, d.window_starts, d.window_samples, d.signals)
    return [classifier.decide(d, m[i], q[i]) for i in range(len(CORNERS))]


def test_healthy_bits_at_the_envelopes_corners_raise_no_alarm(
        envelope: tuple[ActuatorParams, Dictionary]) -> None:
    params, d = envelope
    decisions = _decide(params, d, FaultSet(), 810_000)
    assert not any("inconclusive" in dec.evidence for dec in decisions)
    alarms = [(c, dec.fault) for c, dec in zip(CORNERS, decisions, strict=True) if dec.anomaly]
    assert alarms == []
    worst = max(dec.score / dec.threshold for dec in decisions)
    assert worst < 1.0


def test_a_fault_at_the_envelopes_corners_is_named(
        envelope: tuple[ActuatorParams, Dictionary]) -> None:
    params, d = envelope
    decisions = _decide(params, d, FaultSet.of([at_severity(params, "esr", 0.7)]), 820_000)
    named = [dec.anomaly and dec.fault == "esr" for dec in decisions]
    assert all(named), [(c, dec.fault) for c, dec in zip(CORNERS, decisions, strict=True)]
    err = np.abs(np.array([dec.severity for dec in decisions], dtype=np.float64) - 0.7)
    assert err.mean() < 0.15 and err.max() < 0.3, err   # a small dictionary: 24 ESR runs
