"""Two faults at once read against a commissioned unit's baseline: named as the pair with both
severities, in the event's compound evidence; a single fault is not called a pair; a BIT
nothing explains is said to be unexplained rather than one fault."""

from __future__ import annotations

import pytest

from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.pairs import PairReading, candidates
from mapr_daemon.reasoner.commissioning.severity import Reading
from mapr_daemon.reasoner.commissioning.unit_decision import combine, verdict
from mapr_daemon.reasoner.diagnosis.classifier import Decision
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training.corpus import Runs, simulate_bit
from tests.reasoner.conftest import Bench, commissioned_folder

TRUTH = {"esr": 0.6, "friction": 0.7}
SINGLE = {"friction": 0.7}


@pytest.fixture(scope="module")
def unit(bench: Bench, tmp_path_factory: pytest.TempPathFactory) -> Baseline:
    return Baseline.load(commissioned_folder(bench, tmp_path_factory.mktemp("unit")))


@pytest.fixture(scope="module")
def faulted(bench: Bench) -> Runs:
    """One BIT with ESR and friction at once, one with the friction alone (other seeds and a
    pressure the commissioning did not fly)."""
    sets = [FaultSet.of([at_severity(bench.params, k, s) for k, s in t.items()])
            for t in (TRUTH, SINGLE)]
    return simulate_bit(bench.params, sets, [900.0, 900.0], [61_001, 61_002],
                        ambient_c=[15.0, 15.0], bus_v=[None, None])


def _read(unit: Baseline, runs: Runs, i: int) -> Reading:
    r = unit.read({k: v[i] for k, v in runs.channels.items()}, runs.command_deg,
                  float(runs.dynamic_pressure_pa[i]))
    assert isinstance(r, Reading), r
    return r


def test_a_pair_on_a_commissioned_unit_is_named_with_both_severities(
        bench: Bench, unit: Baseline, faulted: Runs) -> None:
    r = _read(unit, faulted, 0)
    assert r.pair is not None and {r.pair.first, r.pair.second} == set(TRUTH)
    read = {r.pair.first: r.pair.severity_first, r.pair.second: r.pair.severity_second}
    for mode, s in TRUTH.items():
        assert abs(read[mode] - s) < 0.1, read
    assert verdict(r) == "pair"
    # the event names both faults as the dictionary path does (evidence.compound)
    dictionary_said = Decision(True, "esr", None, 0.5, 0.01, "ohm", 0.9, 5.0, 1.0, {})
    dec = combine(dictionary_said, r, unit)
    assert dec.pair is not None and {m.fault for m in dec.pair} == set(TRUTH)
    event = Reasoner(bench.dictionary, bench.params, baseline=unit).event(dec)
    members = {m["fault"]: m for m in event.evidence["compound"]["faults"]}
    assert set(members) == set(TRUTH)
    assert {m["part"] for m in members.values()} == {"SMPS output capacitor", "motor and gear"}
    assert abs(members["friction"]["severity_fraction_of_range"] - 0.7) < 0.1
    assert event.evidence["reading"] == "baseline"
    assert event.evidence["baseline"]["pair"]["modes"] == [r.pair.first, r.pair.second]


def test_a_single_fault_is_not_called_a_pair(unit: Baseline, faulted: Runs) -> None:
    r = _read(unit, faulted, 1)
    assert verdict(r) == "single"
    assert r.mode == "friction" and abs(r.severity - SINGLE["friction"]) < 0.1
    dictionary_said = Decision(True, "friction", None, 0.5, 2.0, "x", 0.9, 5.0, 1.0, {})
    assert combine(dictionary_said, r, unit).pair is None


def test_what_nothing_explains_is_unexplained_not_one_fault(unit: Baseline) -> None:
    dictionary_said = Decision(True, "esr", None, 0.5, 0.01, "ohm", 0.9, 5.0, 1.0, {})
    pair = PairReading("esr", "friction", 0.5, 0.5, cost=23.0)
    neither = Reading("esr", "", 0.5, cost=25.0, healthy_cost=40.0, costs={}, pair=pair)
    dec = combine(dictionary_said, neither, unit)
    assert dec.anomaly and dec.fault is None and dec.pair is None
    assert dec.evidence["unexplained"].startswith("anomaly, not explained")
    assert dec.evidence["closest"]["pair"] == ["esr", "friction"]
    # a pair that gains no more than a second severity could by chance is not named
    slight = PairReading("esr", "friction", 0.5, 0.05, cost=1.9)
    close = Reading("esr", "", 0.5, cost=2.2, healthy_cost=40.0, costs={}, pair=slight)
    assert verdict(close) == "single" and combine(dictionary_said, close, unit).pair is None


def test_only_the_best_modes_of_different_parts_make_pairs() -> None:
    costs = {"esr": 1.0, "capacitance": 2.0, "friction": 3.0, "smps_ron_high": 9.0}
    assert candidates(costs, list(costs), top=3) == [("esr", "friction"),
                                                     ("capacitance", "friction")]
