"""A unit learned in service: healthy BITs refine its calibration, a fault is never learned.

A unit drawn off the data sheet by the mismatch harness is commissioned on 5 healthy BITs,
then flies healthy BITs with one faulted BIT among them, and a second stream in which its
friction grows from nominal to 60 % of its range: the learner calibrates afresh at 10 and 20
BITs, never learns the faulted BIT nor a BIT its commissioning calibration flags, and flags the
grown friction at the end.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.commissioning.in_service import InServiceLearning
from mapr_daemon.reasoner.diagnosis import classifier
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.training.corpus import simulate_bit
from mapr_daemon.reasoner.training.dictionary_build import run_matrices
from mapr_daemon.testbed.mismatch import fleet

HEALTHY = 26
DRIFT = 40


def _fly(d: Dictionary, faults: list[FaultSet], seed: int) -> tuple[np.ndarray, list[float]]:
    sheet = load_actuator(default_actuator_path())
    unit = fleet(sheet, 1, 404)[0]
    rng = np.random.default_rng(seed)
    env = sheet.envelope
    specs: list[RunSpec] = [
        unit.spec(f, seed=int(rng.integers(10**9, 2**40)),
                  ambient_c=float(rng.uniform(env.ambient_min_c, env.ambient_max_c)),
                  bus_v=float(rng.uniform(sheet.bus.nominal_v - 1.0, sheet.bus.nominal_v + 1.0)))
        for f in faults]
    q = [float(v) for v in rng.uniform(0.0, 1600.0, len(faults))]
    runs = simulate_bit(sheet, [], q, [], specs=specs)
    return run_matrices(runs, d.window_starts, d.window_samples, d.signals), q


@pytest.fixture(scope="module")
def model(dictionary: Path) -> Dictionary:
    return Dictionary.load(dictionary)


def test_healthy_bits_refine_the_unit_and_a_fault_is_not_learned(model: Dictionary) -> None:
    sheet = load_actuator(default_actuator_path())
    faults = [FaultSet()] * HEALTHY
    faulted = 12
    faults[faulted] = FaultSet.of([at_severity(sheet, "esr", 0.8)])
    m, q = _fly(model, faults, 77)
    learner = InServiceLearning(model, list(m[:5]), list(q[:5]))
    assert learner.refits == 1 and learner.report.bits == 5
    decisions = [learner.observe(m[i], q[i]) for i in range(5, HEALTHY)]
    assert decisions[faulted - 5].anomaly and decisions[faulted - 5].fault == "esr"
    assert learner.refused["alarm"] >= 1
    # the faulted BIT's matrix is not among those the unit is calibrated on
    assert not any(np.array_equal(m[faulted], mi) for mi in learner.m)
    # refits at 10 and at 20 BITs; the calibration now rests on what was learned
    assert learner.bits >= 10 and learner.refits >= 2
    assert learner.report.bits == max(b for b in (5, 10, 20) if b <= learner.bits)
    assert learner.frozen is None
    assert sum(learner.refused.values()) + learner.bits - 5 == HEALTHY - 5


def test_a_slowly_growing_fault_is_flagged_not_absorbed(model: Dictionary) -> None:
    sheet = load_actuator(default_actuator_path())
    sev = np.concatenate([np.zeros(5), np.linspace(0.0, 0.6, DRIFT - 5)])
    faults = [FaultSet() if s == 0 else FaultSet.of([at_severity(sheet, "friction", float(s))])
              for s in sev]
    m, q = _fly(model, faults, 78)
    learned: dict[bool, list[float]] = {}
    flagged: dict[bool, list[bool]] = {}
    for guarded in (True, False):
        learner = InServiceLearning(model, list(m[:5]), list(q[:5]), guarded=guarded)
        flagged[guarded] = [learner.observe(m[i], q[i]).anomaly for i in range(5, DRIFT)]
        learned[guarded] = [float(sev[i]) for i in range(5, DRIFT)
                            if any(np.array_equal(m[i], mi) for mi in learner.m)]
    # nothing the commissioning calibration flags is ever learned as health
    commissioned = InServiceLearning(model, list(m[:5]), list(q[:5])).current
    assert not any(classifier.decide(commissioned, m[i], q[i]).anomaly
                   for i in range(5, DRIFT) if float(sev[i]) in learned[True])
    # the grown fault is flagged at the end, at least as often as without the guard
    assert all(flagged[True][-2:]), flagged[True]
    assert sum(flagged[True][-10:]) >= sum(flagged[False][-10:])
    # and learning from every BIT without an alarm takes in at least as much of it
    assert max(learned[False]) >= max(learned[True])
