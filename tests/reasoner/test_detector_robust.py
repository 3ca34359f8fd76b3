"""The unit's detector on bad input: a malformed record's detector is one clear config error
naming the file, a tail fit never lands on NaN or on a threshold below the all-zero floor,
and whatever the detector raises in service leaves the dictionary's decision."""

from __future__ import annotations

import math

import pytest

from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning import detector as det
from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.detection import decide
from mapr_daemon.reasoner.commissioning.detector import Detector, Tail
from mapr_daemon.reasoner.commissioning.severity import Reading
from mapr_daemon.reasoner.diagnosis.classifier import Decision
from mapr_daemon.reasoner.reasoner import Reasoner


def _doc(**over: float) -> dict:
    tail = {"scale": 0.1, "dof": 5.0, "threshold": 2.0, "largest_held_out": 1.0,
            "held_out": [0.1, 0.2, 0.3, 0.4]}
    tail.update(over)
    return {"rule": det.RULE, "alpha": 0.001,
            "statistics": {"no_fault": dict(tail), "explained": dict(tail)}}


@pytest.mark.parametrize("bad", [{"scale": 0.0}, {"scale": -1.0}, {"dof": 0.0},
                                 {"scale": math.nan}, {"threshold": math.nan},
                                 {"threshold": math.inf}])
def test_a_detector_with_an_unusable_tail_is_refused_naming_the_file(bad: dict) -> None:
    with pytest.raises(ConfigError, match=r"unit/commissioning\.json: detector"):
        Detector.from_json(_doc(**bad), "unit/commissioning.json")


def test_a_tail_of_all_but_one_zero_is_not_below_the_all_zero_floor() -> None:
    floor = Tail.fit([0.0, 0.0, 0.0, 0.0], 5e-4).threshold
    almost = Tail.fit([0.0, 0.0, 0.0, 1e-9], 5e-4).threshold
    assert almost >= floor


def test_non_finite_held_out_values_calibrate_no_detector(
        monkeypatch: pytest.MonkeyPatch) -> None:
    nan = Reading("healthy", "", 0.0, math.nan, math.nan, {})
    monkeypatch.setattr(det, "held_out_discrepancies", lambda *a: [None] * 5)
    monkeypatch.setattr(det, "held_out_readings", lambda *a: [nan] * 5)
    with pytest.raises(ConfigError, match="detector"):
        det.calibrate(None, None, None, [None] * 5)  # type: ignore[arg-type]


def test_a_detector_that_raises_in_service_keeps_the_dictionarys_decision(
        monkeypatch: pytest.MonkeyPatch) -> None:
    tail = Tail(0.0, 5.0, 1.0, 1.0)  # what a hand-edited record could hold
    detector = Detector(0.001, {"no_fault": tail, "explained": tail},
                        {"no_fault": (), "explained": ()})
    reasoner = Reasoner.__new__(Reasoner)
    reasoner.baseline = Baseline(None, None, None, detector)  # type: ignore[arg-type]
    reading = Reading("friction", "", 0.5, 2.0, 5.0, {"friction": 2.0})
    monkeypatch.setattr(reasoner, "baseline_reading", lambda *a: reading)
    for anomaly in (False, True):
        dec = Decision(anomaly, "friction" if anomaly else None, None, None, None, None,
                       0.9, 1.0, 0.5, {"template": "t"})
        out = reasoner.against_baseline(dec, {}, None, 700.0)  # type: ignore[arg-type]
        assert out.anomaly == anomaly and out.fault == dec.fault
        if anomaly:
            assert "ZeroDivisionError" in out.evidence["baseline"]["unreadable"]


def _unexplained_dictionary_decision() -> Decision:
    return Decision(True, None, None, None, None, None, 0.9, 1.0, 0.5,
                    {"unexplained": "anomaly, not explained by any known fault mode: ...",
                     "departures": [], "closest": {"fault": "esr"}})


def test_a_single_fault_the_baseline_names_drops_the_dictionarys_unexplained() -> None:
    reading = Reading("short", "a_high", 0.0, 1.0, 10.0, {"short": 1.0})
    out = decide(_unexplained_dictionary_decision(), reading, Baseline(None, None, None))
    assert out.fault == "short"
    for key in ("unexplained", "departures", "closest"):
        assert key not in out.evidence, key


def test_a_bit_only_the_detector_flags_and_nothing_explains_says_so() -> None:
    tail = Tail(0.01, 5.0, 0.1, 0.05)
    detector = Detector(0.001, {"no_fault": Tail(0.2, 5.0, 5.0, 1.0), "explained": tail},
                        {"no_fault": (), "explained": ()})
    nominal = Decision(False, None, None, None, None, None, 0.9, 0.1, 0.5, {"template": "t"})
    reading = Reading("short", "a_high", 0.0, 0.8, 1.2, {"short": 0.8})  # drop 0.4: fired
    out = decide(nominal, reading, Baseline(None, None, None, detector))
    assert out.anomaly and out.fault is None
    assert out.evidence["detection"]["decided_by"] == ["baseline.explained"]
    assert out.evidence["unexplained"].startswith(
        "anomaly, not explained by any known fault mode")
