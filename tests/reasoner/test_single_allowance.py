"""What a single fault may leave on this unit, from the unit's own calibration: a BIT whose
best single fault leaves more than the unit allows is named as a pair or as unexplained (with
where it departs), never as that single fault; a true single fault within the allowance stays
a single fault; the allowance is kept in the record, and an older record keeps the older
rule."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.bits import from_runs
from mapr_daemon.reasoner.commissioning.detector import (
    Allowance,
    Detector,
    Tail,
    held_out_readings,
    single_allowance,
)
from mapr_daemon.reasoner.commissioning.discrepancy import held_out_discrepancies
from mapr_daemon.reasoner.commissioning.pairs import PairReading
from mapr_daemon.reasoner.commissioning.severity import Reading
from mapr_daemon.reasoner.commissioning.unit_decision import combine, explains, verdict
from mapr_daemon.reasoner.diagnosis.classifier import Decision
from mapr_daemon.reasoner.training.corpus import Runs, simulate_bit
from tests.reasoner.conftest import HELD_OUT, Bench, commissioned_folder

ALLOW = Allowance(healthy=3.0, share=0.05, shares={"friction": 0.02}, alpha=0.05,
                  excess={"esr": (0.01, 0.03, 0.02)})
"""A unit whose healthy scatter leaves up to 3 and whose true singles left up to 5 % of what
they explained."""
WHERE = {"signals": [{"signal": "smps_input_current_a", "share": 0.6}],
         "phases_ms": [{"from": 300.0, "to": 400.0, "share": 0.5}]}
DICTIONARY_SAID = Decision(True, "esr", None, 0.5, 0.01, "ohm", 0.9, 5.0, 1.0, {})


def _reading(cost: float, healthy_cost: float, pair_cost: float | None,
             mode: str = "esr") -> Reading:
    pair = None if pair_cost is None else PairReading("esr", "friction", 0.6, 0.5, pair_cost)
    return Reading(mode, "", 0.6, cost, healthy_cost, {}, pair, WHERE)


@pytest.fixture(scope="module")
def unit(bench: Bench, tmp_path_factory: pytest.TempPathFactory) -> Baseline:
    """The twin commissioned from six BITs, with a synthetic allowance (what is tested here is
    the rule, not the calibration)."""
    base = Baseline.load(commissioned_folder(bench, tmp_path_factory.mktemp("unit")))
    tail = Tail(0.1, 10.0, 5.0, 1.0)
    det = Detector(0.001, {"no_fault": tail, "explained": tail},
                   {"no_fault": (1.0,), "explained": (0.1,)}, ALLOW)
    return dataclasses.replace(base, detector=det)


def test_a_single_leaving_more_than_the_unit_allows_is_not_that_single(unit: Baseline) -> None:
    # esr takes 50 of 60 away: by the older share rule (at most half left) it "explains" the
    # BIT, but 10 is far beyond the 3 + 0.05 x 50 a true single leaves on this unit
    r = _reading(10.0, 60.0, pair_cost=4.0)
    assert explains(r) and not explains(r, ALLOW)
    assert verdict(r, ALLOW) == "pair"
    dec = combine(DICTIONARY_SAID, r, unit)
    assert dec.pair is not None and {m.fault for m in dec.pair} == {"esr", "friction"}
    # no pair fits either: unexplained, saying where it departs and what it is near
    worse = _reading(10.0, 60.0, pair_cost=8.5)
    assert verdict(worse, ALLOW) == "unexplained"
    dec = combine(DICTIONARY_SAID, worse, unit)
    assert dec.anomaly and dec.fault is None and dec.pair is None
    ev = dec.evidence
    assert ev["unexplained"].startswith("anomaly, not explained by any known fault mode")
    assert ev["departures"]["signals"][0]["signal"] == "smps_input_current_a"
    assert ev["departures"]["phases_ms"] == WHERE["phases_ms"]
    assert ev["departures"]["points_at"] == "SMPS output capacitor"
    assert ev["baseline"]["verdict"] == "unexplained" and not ev["baseline"]["explains"]
    assert ev["baseline"]["allowance"]["false_rate"] == 0.05


def test_a_true_single_within_the_allowance_stays_a_single(unit: Baseline) -> None:
    r = _reading(4.5, 60.0, pair_cost=3.9)   # 4.5 <= 3 + 0.05 x 55.5; the pair gains 0.6
    assert verdict(r, ALLOW) == "single"
    dec = combine(DICTIONARY_SAID, r, unit)
    assert dec.fault == "esr" and dec.pair is None and dec.severity == pytest.approx(0.6)
    # a single that fits is kept even when a pair would fit a little better still
    assert verdict(_reading(4.5, 60.0, pair_cost=2.0), ALLOW) == "single"


def test_a_flag_the_reading_sees_within_the_healthy_scatter_stays_the_dictionarys(
        unit: Baseline) -> None:
    r = _reading(2.6, 2.9, pair_cost=2.5, mode="healthy")
    assert verdict(r, ALLOW) == "dictionary"
    assert combine(DICTIONARY_SAID, r, unit).fault == "esr"


def test_a_short_keeps_the_share_rule(unit: Baseline) -> None:
    r = Reading("short", "A_high", 1.0, 20.0, 60.0, {}, None, WHERE)
    assert verdict(r, ALLOW) == "single"


def test_the_allowance_is_kept_in_the_record_and_an_old_record_has_none(
        bench: Bench, tmp_path: Path) -> None:
    det = Detector(0.001, {"no_fault": Tail(0.1, 10.0, 5.0, 1.0),
                           "explained": Tail(0.1, 10.0, 5.0, 1.0)},
                   {"no_fault": (1.0,), "explained": (0.1,)}, ALLOW)
    doc = json.loads(json.dumps(det.to_json()))
    assert Detector.from_json(doc).allowance == ALLOW
    del doc["single_allowance"]
    assert Detector.from_json(doc).allowance is None
    bad = det.to_json()
    bad["single_allowance"]["share"] = -1.0
    with pytest.raises(ConfigError, match="detector"):
        Detector.from_json(bad)


PAIR = {"esr": 0.6, "friction": 0.7}
SINGLE = {"friction": 0.7}


@pytest.fixture(scope="module")
def calibrated(bench: Bench, tmp_path_factory: pytest.TempPathFactory) -> Baseline:
    """The twin commissioned from six BITs, its allowance calibrated on them with two ESR or
    friction faults added to each (the bench's dictionary's kinds; enough of each for a
    share per mode)."""
    base = Baseline.load(commissioned_folder(bench, tmp_path_factory.mktemp("cal")))
    own = bench.runs.n - len(HELD_OUT)
    bits = from_runs(bench.runs, "bench",
                     [i for i in range(own) if bench.runs.labels[i] == "healthy"][:6])
    discs = held_out_discrepancies(base.discrepancy, base.params, bits)
    healthy = held_out_readings(base.params, base.datasheet, base.discrepancy, bits, discs)
    allowance = single_allowance(base.params, base.datasheet, discs, bits, healthy,
                                 kinds=("esr", "friction"), per_bit=2)
    costs = sorted(r.healthy_cost for r in healthy)
    assert costs[len(costs) // 2] < allowance.healthy  # above the typical healthy BIT
    tail = Tail(0.1, 10.0, 5.0, 1.0)  # the detector's thresholds play no part here
    return dataclasses.replace(base, detector=Detector(
        0.001, {"no_fault": tail, "explained": tail}, {"no_fault": (), "explained": ()},
        allowance))


@pytest.fixture(scope="module")
def faulted(bench: Bench) -> Runs:
    sets = [FaultSet.of([at_severity(bench.params, k, s) for k, s in t.items()])
            for t in (PAIR, SINGLE)]
    return simulate_bit(bench.params, sets, [900.0, 900.0], [61_101, 61_102],
                        ambient_c=[15.0, 15.0], bus_v=[None, None])


def test_on_a_calibrated_unit_a_pair_is_not_a_single_and_a_single_is(
        calibrated: Baseline, faulted: Runs) -> None:
    assert calibrated.detector is not None
    allowance = calibrated.detector.allowance
    assert allowance is not None and set(allowance.shares) == {"esr", "friction"}
    readings = []
    for i in range(2):
        r = calibrated.read({k: v[i] for k, v in faulted.channels.items()},
                            faulted.command_deg, float(faulted.dynamic_pressure_pa[i]))
        assert isinstance(r, Reading), r
        readings.append(r)
    both, one = readings
    assert not explains(both, allowance)
    assert verdict(both, allowance) in ("pair", "unexplained")
    assert verdict(one, allowance) == "single" and one.mode == "friction"


@pytest.mark.parametrize("field", ["shares", "excess"])
def test_a_malformed_allowance_is_a_config_error_naming_the_detector(field: str) -> None:
    """A hand-edited or damaged record whose allowance's per-mode table is not a mapping is
    refused as a malformed detector (the daemon's config error), not an AttributeError that
    escapes the loaders' guards and stops the daemon with a traceback."""
    det = Detector(0.001, {"no_fault": Tail(0.1, 10.0, 5.0, 1.0),
                           "explained": Tail(0.1, 10.0, 5.0, 1.0)},
                   {"no_fault": (1.0,), "explained": (0.1,)}, ALLOW)
    bad = json.loads(json.dumps(det.to_json()))
    bad["single_allowance"][field] = [0.02]
    with pytest.raises(ConfigError, match="malformed detector"):
        Detector.from_json(bad)


def test_mapr_commission_keeps_the_allowance_only_when_asked(bench: Bench,
                                                            tmp_path: Path) -> None:
    """`mapr commission` calibrates the unit's detector without the single-fault allowance
    (its older decision: fewer true single faults said "unexplained"); with
    `--single-allowance` the record keeps it, and says so in the detector's line."""
    import types

    from mapr_daemon.reasoner.commissioning.discrepancy import learn_unit
    from mapr_daemon.reasoner.commissioning.workflow import unit_detector

    own = bench.runs.n - len(HELD_OUT)
    healthy = [i for i in range(own) if bench.runs.labels[i] == "healthy"][:6]
    bits = from_runs(bench.runs, "bench", healthy)
    disc = learn_unit(bench.params, bits, 10)
    ident = types.SimpleNamespace(params=bench.params, bits=bits)
    said: list[str] = []
    off = unit_detector(ident, bench.params, bits, disc, None,  # type: ignore[arg-type]
                        said.append)
    on = unit_detector(ident, bench.params, bits, disc,  # type: ignore[arg-type]
                       held_out_discrepancies(disc, bench.params, bits), said.append,
                       allowance=True)
    assert off is not None and "single_allowance" not in off
    assert on is not None and on["single_allowance"]["healthy"] > 0
    assert Detector.from_json(off).allowance is None
    assert Detector.from_json(on).allowance is not None
