"""The unit's own anomaly detector on the baseline reading: a healthy BIT of the unit is not
flagged, a small fault the dictionary misses is, an old record without a detector keeps the
dictionary's detection, and the threshold's tail fit lands where the tail is."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.errors import ConfigError
from mapr_daemon.findings import Diagnosis
from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.detection import decide
from mapr_daemon.reasoner.commissioning.detector import Detector, Tail
from mapr_daemon.reasoner.commissioning.severity import Reading
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training.corpus import Runs, simulate_bit
from tests.reasoner.conftest import HELD_OUT, Bench, commissioned_folder

Q_PA = 700.0


@pytest.fixture(scope="module")
def with_detector(bench: Bench, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return commissioned_folder(bench, tmp_path_factory.mktemp("unit"), detector=True)


@pytest.fixture(scope="module")
def old_record(bench: Bench, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return commissioned_folder(bench, tmp_path_factory.mktemp("old"))


@pytest.fixture(scope="module")
def small_friction(bench: Bench) -> Runs:
    """Friction 8 % of its range: below what the bench's dictionary flags, a departure in a
    direction the unit's healthy scatter does not go in."""
    fault = FaultSet.of([at_severity(bench.params, "friction", 0.08)])
    return simulate_bit(bench.params, [fault], [Q_PA], [61001])


def _diagnose(runs: Runs, i: int, reasoner: Reasoner) -> Diagnosis:
    channels = {k: v[i] for k, v in runs.channels.items()}
    return reasoner.diagnose(channels, runs.command_deg, float(runs.dynamic_pressure_pa[i]))


def test_the_units_healthy_bits_are_not_flagged(bench: Bench, with_detector: Path) -> None:
    baseline = Baseline.load(with_detector)
    assert baseline.detector is not None
    reasoner = Reasoner(bench.dictionary, bench.params, baseline=baseline)
    for j, (kind, _, _) in enumerate(HELD_OUT):
        if kind != "healthy":
            continue
        out = _diagnose(bench.runs, bench.runs.n - len(HELD_OUT) + j, reasoner)
        assert not out.anomaly, out.evidence
        detection = out.evidence["detection"]
        assert detection["fired"] == [] and detection["decided_by"] == []
        for stat in detection["baseline"].values():
            assert not stat["fired"] and stat["value"] < stat["threshold"]


def test_a_small_fault_the_dictionary_misses_is_flagged_by_the_units_detector(
        bench: Bench, with_detector: Path, small_friction: Runs) -> None:
    alone = _diagnose(small_friction, 0, Reasoner(bench.dictionary, bench.params))
    assert not alone.anomaly
    out = _diagnose(small_friction, 0, Reasoner(bench.dictionary, bench.params,
                                                baseline=Baseline.load(with_detector)))
    assert out.anomaly
    detection = out.evidence["detection"]
    assert not detection["dictionary"]
    assert "baseline.explained" in detection["fired"]
    assert detection["decided_by"] == ["baseline.explained"]
    assert out.fault == "friction" and out.part == "motor and gear"
    assert 0.0 < out.confidence <= 1.0


def test_an_old_record_without_a_detector_keeps_the_dictionarys_detection(
        bench: Bench, old_record: Path, small_friction: Runs) -> None:
    doc = json.loads((old_record / "commissioning.json").read_text())
    assert "detector" not in doc
    baseline = Baseline.load(old_record)
    assert baseline.detector is None
    alone = Reasoner(bench.dictionary, bench.params)
    old = Reasoner(bench.dictionary, bench.params, baseline=baseline)
    a, b = _diagnose(small_friction, 0, alone), _diagnose(small_friction, 0, old)
    assert not b.anomaly and b == a  # a BIT the dictionary calls nominal is not read
    i = bench.runs.n - len(HELD_OUT)
    assert _diagnose(bench.runs, i, old) == _diagnose(bench.runs, i, alone)


def test_the_detector_is_kept_in_the_record_and_a_malformed_one_refused(
        with_detector: Path, tmp_path: Path) -> None:
    doc = json.loads((with_detector / "commissioning.json").read_text())
    kept = Detector.from_json(doc["detector"])
    assert kept == Baseline.load(with_detector).detector
    assert kept.alpha == pytest.approx(1e-3)
    for name, tail in kept.tails.items():
        assert tail.threshold >= max(kept.held_out[name])
        assert len(kept.held_out[name]) == 6
    with pytest.raises(ConfigError, match="detector"):
        Detector.from_json({"alpha": 0.001, "statistics": {"no_fault": {}}})


def test_the_tail_fit_puts_the_threshold_at_the_tails_quantile() -> None:
    rng = np.random.default_rng(7)
    for scale, dof in ((0.05, 20.0), (0.5, 3.0)):
        x = scale * rng.chisquare(dof, 400)
        tail = Tail.fit(list(x), 5e-4)
        truth = scale * stats.chi2.isf(5e-4, dof)
        assert tail.threshold == pytest.approx(truth, rel=0.15)
        assert 1e-4 < tail.exceedance(truth) < 2.5e-3  # a tail probability: within x5


def test_each_rule_on_a_dictionary_alarm_the_reading_calls_healthy(
        bench: Bench, with_detector: Path) -> None:
    baseline = Baseline.load(with_detector)
    reasoner = Reasoner(bench.dictionary, bench.params)
    i = bench.runs.n - len(HELD_OUT) + 4  # friction 0.8: the dictionary flags it
    dec = reasoner.decide(reasoner.matrix({k: v[i] for k, v in bench.runs.channels.items()},
                                          bench.runs.command_deg),
                          float(bench.runs.dynamic_pressure_pa[i]))
    assert dec.anomaly
    within = Reading("healthy", "", 0.0, 0.9, 0.9, {"healthy": 0.9})
    for rule in ("dictionary", "union", "explained"):
        out = decide(dec, within, baseline, rule)
        assert out.anomaly and out.evidence["detection"]["decided_by"] == ["dictionary"]
    vetoed = decide(dec, within, baseline, "baseline")
    assert not vetoed.anomaly and vetoed.fault is None
    assert vetoed.evidence["vetoed"]["fault"] == dec.fault
    with pytest.raises(ValueError, match="rule"):
        decide(dec, within, baseline, "either")
