"""Model adaptation through the Reasoner's public API: a parameter change confirmed on
consecutive BITs moves the reference model, the event says so, and later records measure
change from the adapted model."""

from __future__ import annotations

import dataclasses

import pytest

from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.findings import Diagnosis
from mapr_daemon.reasoner.ekf.estimator import Confirmation, Estimate
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training.corpus import Runs, simulate_bit
from tests.reasoner.conftest import Bench

FRICTION = (3.0, 3.0, 3.0, 5.0)
"""Friction factor of the unit on four successive BITs."""


@dataclasses.dataclass
class Records:
    runs: Runs


@pytest.fixture(scope="module")
def records(bench: Bench) -> Records:
    fs = [FaultSet.of([Fault("friction", f)]) for f in FRICTION]
    qs = [900.0, 1300.0, 1500.0, 1100.0]
    return Records(simulate_bit(bench.params, fs, qs, [603, 604, 605, 607]))


def _diagnose(r: Reasoner, runs: Runs, i: int) -> Diagnosis:
    ch = {k: v[i] for k, v in runs.channels.items()}
    return r.diagnose(ch, runs.command_deg, float(runs.dynamic_pressure_pa[i]))


def test_a_change_seen_on_three_consecutive_bits_adapts_the_reference(
        bench: Bench, records: Records) -> None:
    r = Reasoner(bench.dictionary, bench.params, confirm_after=3)
    events = [_diagnose(r, records.runs, i) for i in range(4)]
    ev = [e.evidence for e in events]
    coulomb = [e.parameters["coulomb"]["value"] for e in events]
    # x3 friction: the Coulomb term is reported changed from the nominal model each time
    for i in range(3):
        assert "coulomb" in ev[i]["parameter_changes"], i
        assert coulomb[i] > 2.0
    assert "model_adaptation" not in ev[0] and "model_adaptation" not in ev[1]
    adapted = ev[2]["model_adaptation"]
    assert "3 consecutive BITs" in adapted["rule"]
    step = adapted["parameters"]["coulomb"]
    assert step["from"] == 1.0
    assert step["to"] == pytest.approx(sum(coulomb[:3]) / 3, rel=1e-4)
    assert r.reference.value["coulomb"] == pytest.approx(step["to"])
    # the next record (x5) is measured from the adapted model, not from nominal
    after = events[3].parameters["coulomb"]
    assert after["reference"] == pytest.approx(step["to"], rel=1e-4)
    change = ev[3]["parameter_changes"].get("coulomb")
    if change is not None:
        assert change == pytest.approx(after["value"] - step["to"], rel=1e-3)
    assert after["value"] - step["to"] < after["value"] - 1.0 - 1.0
    assert "coulomb" not in ev[3].get("model_adaptation", {}).get("parameters", {})
    assert len(r.reference.history) == 1


def _est(**values: float) -> Estimate:
    return Estimate(dict(values), {k: 0.01 for k in values})


def test_confirmation_needs_the_same_direction_on_consecutive_records() -> None:
    c = Confirmation(3)
    assert c.observe({"coulomb": 1.0}, _est(coulomb=2.0)) == {}
    assert c.observe({"coulomb": 1.2}, _est(coulomb=2.2)) == {}
    assert c.pending() == {"coulomb": 2}
    # a record without the change restarts the count
    assert c.observe({}, _est(coulomb=1.0)) == {}
    assert c.pending() == {}
    for v in (2.0, 2.2):
        c.observe({"coulomb": v - 1.0}, _est(coulomb=v))
    # the other direction restarts it too
    assert c.observe({"coulomb": -0.5}, _est(coulomb=0.5)) == {}
    assert c.pending() == {"coulomb": 1}
    c.observe({"coulomb": -0.6}, _est(coulomb=0.4))
    assert c.observe({"coulomb": -0.7}, _est(coulomb=0.3)) == {"coulomb": pytest.approx(0.4)}
    assert c.pending() == {}
