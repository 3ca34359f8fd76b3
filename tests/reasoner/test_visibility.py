"""What a commissioned unit's own BITs can see of each fault mode
(reasoner/commissioning/visibility.py)."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning import calibrate, visibility
from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.bits import BitRecord, from_runs
from mapr_daemon.reasoner.commissioning.visibility import Visibility
from mapr_daemon.reasoner.diagnosis import classifier
from mapr_daemon.reasoner.reasoner import Reasoner

from .conftest import HELD_OUT, Bench, commissioned_folder


def _healthy(bench: Bench, count: int) -> list[BitRecord]:
    own = bench.runs.n - len(HELD_OUT)
    picks = [i for i in range(own) if bench.runs.labels[i] == "healthy"][:count]
    return from_runs(bench.runs, "bench", picks)


def test_no_fault_departs_by_nothing_and_an_esr_fault_raises_the_ripple(bench: Bench) -> None:
    (bit,) = _healthy(bench, 1)
    none, esr = visibility.departures(bench.params, bit,
                                      [FaultSet(), FaultSet.of([at_severity(bench.params,
                                                                            "esr", 1.0)])])
    assert all(not np.any(v) for v in none.values())
    assert none.keys() == esr.keys() and "ripple_rms_v" in esr
    assert esr["ripple_rms_v"].mean() > 0.0
    assert esr["position_deg"].shape == bit.channels["position_deg"].shape


def test_a_twin_sees_its_full_range_faults_and_not_a_departure_below_its_scatter(
        bench: Bench) -> None:
    bits = _healthy(bench, 4)
    seen = visibility.measure(bench.dictionary, bench.params, bits,
                              severities=(0.0, 0.01, 1.0))
    assert list(seen.detected) == ["esr", "friction"] and seen.bits == 4
    for none, _, full in seen.detected.values():
        # the range's start is the data sheet's value: the records are decided as recorded
        assert none == 0.0, seen.detected
        # the range's end moves the record far outside a twin's healthy scatter
        assert full >= visibility.SEEN, seen.detected
    # a hundredth of the friction range does not (a hundredth of the ESR range is +19 %
    # of its resistance, which the ripple shows)
    assert seen.detected["friction"][1] < visibility.SEEN, seen.detected
    assert seen.floor("friction") == 1.0 and not seen.sees("friction", 0.5)
    # kept in the record and read back
    back = Visibility.from_json(json.loads(json.dumps(seen.to_json())))
    assert back == seen
    assert seen.to_json()["floor"]["friction"] == 1.0


def test_the_floor_needs_every_larger_severity_seen() -> None:
    v = Visibility((0.25, 0.5, 1.0), {"gap": (1.0, 0.5, 1.0), "early": (0.95, 0.9, 1.0),
                                      "never": (1.0, 1.0, 0.5)}, 20)
    assert v.floor("gap") == 1.0 and v.floor("early") == 0.25 and v.floor("never") is None
    assert v.floor("unmeasured") is None and not v.sees("unmeasured", 1.0)
    assert v.sees("early", 0.3) and not v.sees("gap", 0.75)
    assert v.share_at("gap", 0.75) == pytest.approx(0.75)
    assert v.share_at("early", 0.1) == pytest.approx(0.95)
    lines = v.lines()
    assert lines[0].startswith("gap: seen from 100% of range (detected on the unit's 20 BITs")
    assert lines[2].startswith("never: not seen within its range on this unit")
    # a record keeps the rule it was measured with: its own share, not today's default
    lenient = Visibility(v.severities, v.detected, 20, seen=0.5)
    assert lenient.floor("gap") == 0.25 and lenient.floor("never") == 0.25
    assert Visibility.from_json(lenient.to_json()) == lenient


def test_bits_the_dictionary_cannot_read_are_left_out_and_none_left_is_one_error(
        bench: Bench) -> None:
    good = _healthy(bench, 2)
    short = [dataclasses.replace(b, channels={k: v[:100] for k, v in b.channels.items()},
                                 command_deg=b.command_deg[:100]) for b in good]
    seen = visibility.measure(bench.dictionary, bench.params, [*short[:1], *good],
                              modes=["esr"], severities=(1.0,))
    assert seen.bits == 2 and list(seen.detected) == ["esr"]
    with pytest.raises(ConfigError, match="no BIT the dictionary could decide"):
        visibility.measure(bench.dictionary, bench.params, short, severities=(1.0,))


@pytest.mark.parametrize("doc", [
    {"severities": [0.5, 1.0], "detected": {"esr": [0.5]}, "bits": 3},
    {"severities": [1.0], "detected": {"esr": [1.5]}, "bits": 3},
    {"severities": [1.0], "detected": {"esr": [1.0]}},
    "visibility",
    # what the decision reads severities as: one or more fractions of range, increasing
    {"severities": [], "detected": {}, "bits": 3},
    {"severities": [1.0, 0.5], "detected": {"esr": [1.0, 0.0]}, "bits": 3},
    {"severities": [0.5, 0.5], "detected": {"esr": [1.0, 1.0]}, "bits": 3},
    {"severities": [0.5, 2.0], "detected": {"esr": [1.0, 1.0]}, "bits": 3},
    {"severities": [float("nan")], "detected": {"esr": [1.0]}, "bits": 3},
    {"severities": [1.0], "detected": {"esr": [1.0]}, "bits": 0},
])
def test_a_malformed_visibility_is_one_config_error(doc: object) -> None:
    with pytest.raises(ConfigError, match="malformed visibility") as caught:
        Visibility.from_json(doc, "unit/commissioning.json")
    assert caught.value.path == "unit/commissioning.json"


@pytest.fixture(scope="module")
def unit_folder(bench: Bench, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return commissioned_folder(bench, tmp_path_factory.mktemp("seen"), detector=True)


def _with_visibility(folder: Path, doc: object) -> Path:
    record = json.loads((folder / "commissioning.json").read_text())
    record["unit_calibration"] = {"visibility": doc}
    (folder / "commissioning.json").write_text(json.dumps(record))
    return folder


def test_a_nominal_bit_names_what_the_unit_does_not_see_and_its_floor(
        bench: Bench, unit_folder: Path, tmp_path: Path) -> None:
    i = bench.runs.n - len(HELD_OUT)   # the first held-out healthy run
    channels = {k: v[i] for k, v in bench.runs.channels.items()}
    q = float(bench.runs.dynamic_pressure_pa[i])
    before = Reasoner(bench.dictionary, bench.params, baseline=Baseline.load(unit_folder))
    plain = before.diagnose(channels, bench.runs.command_deg, q)
    assert not plain.anomaly and "not_seen_on_this_unit" not in plain.evidence
    seen = Visibility((0.25, 0.5, 1.0), {"esr": (1.0, 1.0, 1.0), "friction": (0.2, 0.95, 1.0),
                                         "smps_ron_low": (0.0, 0.0, 0.1)}, 20)
    folder = tmp_path / "unit"
    shutil.copytree(unit_folder, folder)
    baseline = Baseline.load(_with_visibility(folder, seen.to_json()))
    assert baseline.visibility == seen
    out = Reasoner(bench.dictionary, bench.params, baseline=baseline).diagnose(
        channels, bench.runs.command_deg, q)
    assert not out.anomaly
    said = out.evidence["not_seen_on_this_unit"]
    assert said["floors"] == {"friction": 0.5, "smps_ron_low": None}, said
    # everything else about the decision is as before
    assert {k: v for k, v in out.evidence.items() if k != "not_seen_on_this_unit"} == \
        plain.evidence
    # a unit that sees every mode from a quarter of its range says nothing more
    folder2 = tmp_path / "all"
    shutil.copytree(unit_folder, folder2)
    everything = Visibility((0.25, 1.0), {"esr": (1.0, 1.0)}, 20)
    out = Reasoner(bench.dictionary, bench.params, baseline=Baseline.load(
        _with_visibility(folder2, everything.to_json()))).diagnose(
        channels, bench.runs.command_deg, q)
    assert "not_seen_on_this_unit" not in out.evidence


def test_a_record_with_a_malformed_visibility_is_refused_naming_it(
        unit_folder: Path, tmp_path: Path) -> None:
    folder = tmp_path / "bad"
    shutil.copytree(unit_folder, folder)
    _with_visibility(folder, {"severities": [1.0], "detected": {"esr": ["x"]}, "bits": 2})
    with pytest.raises(ConfigError, match="malformed visibility") as caught:
        Baseline.load(folder)
    assert caught.value.path == str(folder / "commissioning.json")


def test_a_unit_without_a_detector_names_what_it_does_not_see_too(
        bench: Bench, tmp_path: Path) -> None:
    """A unit commissioned from too few BITs for a detector still measured its visibility
    (mapr commission from 3 BITs does): its nominal BITs must say it as well."""
    folder = commissioned_folder(bench, tmp_path, count=3)
    i = bench.runs.n - len(HELD_OUT)
    channels = {k: v[i] for k, v in bench.runs.channels.items()}
    q = float(bench.runs.dynamic_pressure_pa[i])
    # a record without one (written before) decides exactly as the dictionary alone
    alone = Reasoner(bench.dictionary, bench.params).diagnose(channels, bench.runs.command_deg,
                                                              q)
    before = Reasoner(bench.dictionary, bench.params, baseline=Baseline.load(folder)).diagnose(
        channels, bench.runs.command_deg, q)
    assert not before.anomaly and before.evidence == alone.evidence
    assert before.confidence == alone.confidence
    seen = Visibility((0.25, 1.0), {"esr": (1.0, 1.0), "friction": (0.0, 0.5)}, 3)
    baseline = Baseline.load(_with_visibility(folder, seen.to_json()))
    assert baseline.detector is None
    out = Reasoner(bench.dictionary, bench.params, baseline=baseline).diagnose(
        channels, bench.runs.command_deg, q)
    assert not out.anomaly
    assert out.evidence["not_seen_on_this_unit"]["floors"] == {"friction": None}


@pytest.mark.parametrize("calibration", ["calibrated", [1, 2]])
def test_a_record_whose_unit_calibration_is_not_a_mapping_is_refused_naming_it(
        unit_folder: Path, tmp_path: Path, calibration: object) -> None:
    folder = tmp_path / "odd"
    shutil.copytree(unit_folder, folder)
    record = json.loads((folder / "commissioning.json").read_text())
    record["unit_calibration"] = calibration
    (folder / "commissioning.json").write_text(json.dumps(record))
    with pytest.raises(ConfigError, match="unit_calibration") as caught:
        Baseline.load(folder)
    assert caught.value.path == str(folder / "commissioning.json")


def test_a_bit_recorded_at_another_rate_than_the_model_is_left_out(bench: Bench) -> None:
    """The departure is flown at the model's rate: added sample for sample to a record at
    another rate it would land at the wrong times, and the floor would be wrong unsaid."""
    good = _healthy(bench, 2)
    other = dataclasses.replace(good[0], sample_rate_hz=2.0 * good[0].sample_rate_hz)
    seen = visibility.measure(bench.dictionary, bench.params, [other, good[1]],
                              modes=["esr"], severities=(1.0,))
    assert seen.bits == 1


def test_a_nominal_bit_whose_detector_cannot_decide_still_names_what_is_not_seen(
        bench: Bench, unit_folder: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
        ) -> None:
    """The detector raising leaves the dictionary's nominal decision (never lost): what that
    "no anomaly" does not clear is still said."""
    from mapr_daemon.reasoner.commissioning.detector import Detector

    def broken(self: Detector, reading: object) -> dict[str, float]:
        raise KeyError("no_fault")

    folder = tmp_path / "unit"
    shutil.copytree(unit_folder, folder)
    seen = Visibility((0.25, 1.0), {"friction": (0.0, 1.0)}, 20)
    baseline = Baseline.load(_with_visibility(folder, seen.to_json()))
    monkeypatch.setattr(Detector, "fired", broken)
    i = bench.runs.n - len(HELD_OUT)
    out = Reasoner(bench.dictionary, bench.params, baseline=baseline).diagnose(
        {k: v[i] for k, v in bench.runs.channels.items()}, bench.runs.command_deg,
        float(bench.runs.dynamic_pressure_pa[i]))
    assert not out.anomaly
    assert out.evidence["not_seen_on_this_unit"]["floors"] == {"friction": 1.0}


def test_each_bit_can_be_decided_by_a_calibration_that_never_saw_it(bench: Bench) -> None:
    own = bench.runs.n - len(HELD_OUT)
    picks = [i for i in range(own) if bench.runs.labels[i] == "healthy"][:5]
    bits = from_runs(bench.runs, "bench", picks)
    m, q = bench.m[picks], bench.runs.dynamic_pressure_pa[picks]
    assert calibrate.without_each(bench.dictionary, m[:3], q[:3]) is None  # 2 left: too few
    held = calibrate.without_each(bench.dictionary, m, q)
    assert held is not None and len(held) == 5
    assert all(h.healthy is not None and h.healthy.unit_coef is not None for h in held)
    unit, _ = calibrate.calibrate_unit(bench.dictionary, m, q)
    seen = visibility.measure(unit, bench.params, bits, modes=["friction"],
                              severities=(0.0, 1.0), held_out=held)
    assert seen.held_out and seen.detected["friction"][0] == 0.0
    assert seen.detected["friction"][1] >= visibility.SEEN
    assert Visibility.from_json(json.loads(json.dumps(seen.to_json()))) == seen
    with pytest.raises(ValueError, match="4 held-out dictionaries for 5 BITs"):
        visibility.measure(unit, bench.params, bits, held_out=held[:4])


def test_healthy_bits_a_held_out_calibration_flags_are_counted_and_warned_of(
        bench: Bench) -> None:
    bits = _healthy(bench, 4)
    # a dictionary whose healthy-residual threshold is next to nothing: each healthy BIT
    # flagged as recorded
    deaf = dataclasses.replace(bench.dictionary, calibration={
        **bench.dictionary.calibration, "null_threshold": 1e-12})
    b = bits[0]
    assert classifier.decide(deaf, deaf.record_matrix(b.channels, b.command_deg),
                             b.dynamic_pressure_pa).anomaly
    with pytest.raises(ConfigError, match=r"no BIT the dictionary could decide.*4 of 4 "
                                          r"healthy BITs flagged"):
        visibility.measure(deaf, bench.params, bits, severities=(1.0,))
    seen = visibility.measure(bench.dictionary, bench.params, bits, severities=(1.0,),
                              held_out=[deaf, bench.dictionary, bench.dictionary,
                                        bench.dictionary])
    assert seen.alarmed == 1 and seen.bits == 3
    note = seen.false_alarm_note()
    assert note is not None and note.startswith(
        "1 of the unit's 4 healthy BITs were flagged by the dictionary calibrated without each")
    assert "left out of what its BITs can see" in note
    assert Visibility.from_json(seen.to_json()).alarmed == 1
    assert visibility.measure(bench.dictionary, bench.params, bits,
                              severities=(1.0,)).false_alarm_note() is None
