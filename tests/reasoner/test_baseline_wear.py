"""A commissioned asset's BITs carry each aging kind's wear read against its own baseline,
weighed by the sd measured on its held-out commissioning BITs; an asset without a baseline
(or with a record written before there was a wear reading) keeps the estimators exactly."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.errors import ConfigError
from mapr_daemon.findings import Diagnosis
from mapr_daemon.reasoner.commissioning.baseline import Baseline, record_digest
from mapr_daemon.reasoner.commissioning.bits import from_runs
from mapr_daemon.reasoner.commissioning.discrepancy import Discrepancy
from mapr_daemon.reasoner.commissioning.wear import BaselineWear, fault_at, measure
from mapr_daemon.reasoner.prognosis import trend
from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel
from mapr_daemon.reasoner.prognosis.wear_estimators import WearModel
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training.corpus import Runs, simulate_bit
from tests.reasoner.conftest import HELD_OUT, Bench, commissioned_folder

KINDS = ("esr", "friction")
COUNT = 6


@pytest.fixture(scope="module")
def with_wear(bench: Bench, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A commissioned folder whose record carries the wear noise measured on its BITs."""
    folder = commissioned_folder(bench, tmp_path_factory.mktemp("unit"), count=COUNT)
    own = bench.runs.n - len(HELD_OUT)
    healthy = [i for i in range(own) if bench.runs.labels[i] == "healthy"][:COUNT]
    bits = from_runs(bench.runs, "bench", healthy)
    disc = Discrepancy.load(folder / "discrepancy.npz")
    record = json.loads((folder / "commissioning.json").read_text())
    record["wear"] = measure(bench.params, disc, bits, KINDS).to_json()
    (folder / "commissioning.json").write_text(json.dumps(record))
    return folder


@pytest.fixture(scope="module")
def old_record(bench: Bench, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return commissioned_folder(bench, tmp_path_factory.mktemp("old"), count=COUNT)


@pytest.fixture(scope="module")
def model(bench: Bench) -> PrognosticModel:
    """Estimators that answer something (a fixed forward model) for both kinds."""
    assert bench.dictionary.healthy is not None
    k = int(bench.dictionary.healthy.projection.shape[1])
    rng = np.random.default_rng(3)
    estimators = {kind: WearModel(kind, rng.normal(size=(25, k)), np.eye(k), 0.1, 60)
                  for kind in KINDS}
    return PrognosticModel("EMA", estimators, {kind: trend.Noise(0.05) for kind in KINDS},
                           {}, {})


@pytest.fixture(scope="module")
def worn(bench: Bench) -> Runs:
    """ESR at 0.6 of the way to its failure threshold, friction at 0.5 (the unit's own)."""
    return simulate_bit(bench.params, [fault_at(bench.params, "esr", 0.6),
                                       fault_at(bench.params, "friction", 0.5)],
                        [700.0, 900.0], [62001, 62002])


def _diagnose(runs: Runs, i: int, reasoner: Reasoner) -> Diagnosis:
    channels = {k: v[i] for k, v in runs.channels.items()}
    return reasoner.diagnose(channels, runs.command_deg, float(runs.dynamic_pressure_pa[i]))


def test_an_asset_without_a_baseline_keeps_the_estimators_exactly(
        bench: Bench, model: PrognosticModel, old_record: Path, worn: Runs) -> None:
    for baseline in (None, Baseline.load(old_record)):
        assert baseline is None or baseline.wear is None
        r = Reasoner(bench.dictionary, bench.params, prognostic=model, baseline=baseline)
        for i in range(worn.n):
            out = _diagnose(worn, i, r)
            m = r.matrix({k: v[i] for k, v in worn.channels.items()}, worn.command_deg)
            assert out.wear == model.estimates(bench.dictionary, m,
                                               float(worn.dynamic_pressure_pa[i]))
            assert "wear_against_baseline" not in out.evidence
            assert out.wear_source == {k: {"path": "estimator"} for k in out.wear}


def test_a_commissioned_assets_bits_carry_baseline_read_wear_with_the_measured_sd(
        bench: Bench, model: PrognosticModel, with_wear: Path, worn: Runs) -> None:
    baseline = Baseline.load(with_wear)
    assert baseline.wear is not None
    r = Reasoner(bench.dictionary, bench.params, prognostic=model, baseline=baseline)
    for i, (kind, h) in enumerate((("esr", 0.6), ("friction", 0.5))):
        out = _diagnose(worn, i, r)
        assert out.evidence["wear_against_baseline"] == sorted(KINDS)
        m = r.matrix({k: v[i] for k, v in worn.channels.items()}, worn.command_deg)
        assert out.wear != model.estimates(bench.dictionary, m,
                                           float(worn.dynamic_pressure_pa[i]))
        noise = baseline.wear.kinds[kind]
        assert out.wear[kind] - noise.offset == pytest.approx(h, abs=0.15)
        # the catalog keeps which record read it, and the offset and sd it is weighed by
        assert out.wear_source is not None and set(out.wear_source) == set(out.wear)
        assert out.wear_source[kind] == {
            "path": "baseline", "record": record_digest(with_wear / "commissioning.json"),
            "offset": noise.offset, "sd0": noise.sd0, "sd1": noise.sd1}
    # a healthy BIT the baseline did not see reads near the offset, within its measured sd
    healthy = bench.runs.n - len(HELD_OUT)   # HELD_OUT's first run is healthy
    out = _diagnose(bench.runs, healthy, r)
    for kind in KINDS:
        n = baseline.wear.kinds[kind]
        assert n.sd0 > 0.0 and len(n.held_out) == COUNT
        assert abs(out.wear[kind] - n.offset) < max(4.0 * n.sd0, 0.05)
    # the trend of that asset weighs those readings by the measured sd, not the estimators'
    against = model.against_baseline(baseline.wear.noise())
    for kind in KINDS:
        n = baseline.wear.kinds[kind]
        assert float(against.noise[kind].h_sd(np.array([0.0]))[0]) == pytest.approx(n.sd0)
        assert float(against.noise[kind].calibrate(np.array([n.offset + 0.3]))[0]) == \
            pytest.approx(0.3)
        assert model.noise[kind].sd0 == 0.05   # the shared model is left as it was


def test_the_wear_noise_round_trips_and_a_malformed_one_is_refused(with_wear: Path) -> None:
    doc = json.loads((with_wear / "commissioning.json").read_text())["wear"]
    back = BaselineWear.from_json(doc)
    assert back.to_json() == doc
    bad = {**doc, "kinds": {**doc["kinds"], "esr": {**doc["kinds"]["esr"], "sd0": 0.0}}}
    with pytest.raises(ConfigError, match="sd0"):
        BaselineWear.from_json(bad)


def test_the_daemon_trends_a_commissioned_asset_with_its_measured_noise(
        bench: Bench, model: PrognosticModel, with_wear: Path, old_record: Path,
        tmp_path: Path) -> None:
    """``assets[].commissioned`` with a wear record: the asset's trend weighs the kinds its
    baseline reads by the unit's measured noise; with an older record, by the model's."""
    from mapr_daemon.pipeline.pipeline import build_pipeline
    from mapr_daemon.service.config import Config

    dpath, ppath = tmp_path / "d.npz", tmp_path / "p.npz"
    bench.dictionary.save(dpath)
    model.save(ppath)
    measured = Baseline.load(with_wear).wear
    assert measured is not None
    for folder, expected in ((with_wear, {**model.noise, **measured.noise()}),
                             (old_record, model.noise)):
        config = dataclasses.replace(
            Config(), source="x.yaml",
            assets=(dataclasses.replace(Config().assets[0], commissioned=str(folder),
                                        prognosis=str(ppath)),),
            reasoner=dataclasses.replace(Config().reasoner, dictionary=str(dpath)))
        pipeline = build_pipeline(config)   # type: ignore[arg-type]
        assert pipeline.trending is not None
        assert pipeline.trending.models["EMA1"].noise == expected


def test_a_fleet_worker_reads_a_commissioned_assets_wear_against_its_baseline(
        bench: Bench, model: PrognosticModel, with_wear: Path, worn: Runs,
        tmp_path: Path) -> None:
    """A fleet run's workers diagnose with a fresh reasoner per recording while the client
    trends with the commissioned model (the baseline's noise): the worker's reasoner must
    read the wear against the same baseline, or the estimators' readings are weighed as the
    baseline's (offset subtracted, gain 1)."""
    from mapr_daemon.fleet import task
    from mapr_daemon.service.config import Config

    dpath, ppath = tmp_path / "d.npz", tmp_path / "p.npz"
    bench.dictionary.save(dpath)
    model.save(ppath)
    config = dataclasses.replace(
        Config(), source="fleet.yaml",
        assets=(dataclasses.replace(Config().assets[0], commissioned=str(with_wear),
                                    prognosis=str(ppath)),),
        reasoner=dataclasses.replace(Config().reasoner, dictionary=str(dpath)))
    fresh = task._fresh(config)   # type: ignore[arg-type]
    watch = fresh.watched[0].watch
    assert watch is not None
    assert watch.reasoner.baseline is not None and watch.reasoner.baseline.wear is not None
    out = _diagnose(worn, 1, watch.reasoner)
    assert out.evidence["wear_against_baseline"] == sorted(KINDS)


def test_a_baseline_read_kind_is_trended_without_the_estimators_fleet_offset(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The fleet's unit offset of a kind (trend.UNIT_OFFSET_MEAN/SD: ESR's estimators read
    0.019 low on every unit) belongs to the estimators; a kind read against the unit's own
    baseline has its own offset measured and subtracted, so its RUL must be the trend's with
    no fleet offset, while an asset without a baseline keeps the fleet's exactly."""
    from mapr_daemon.reasoner.prognosis.assessment import assess

    assert trend.UNIT_OFFSET_MEAN.get("esr", 0.0) != 0.0
    plain = PrognosticModel("EMA", {}, {"esr": trend.Noise(0.03)}, {}, {})
    own = plain.against_baseline({"esr": trend.Noise(0.03, 0.0, 0.0, 1.0)})
    flights = [float(f) for f in range(1, 31)]
    rng = np.random.default_rng(5)
    wear = [{"esr": round(0.02 * (f - 1) + 0.03 * float(rng.standard_normal()), 5)}
            for f in flights]

    def rul(model: PrognosticModel) -> float:
        return assess(model, flights, wear, diagnosed="esr", seed=1).modes["esr"]["rul"]

    with_fleet = rul(plain), rul(own)
    monkeypatch.setattr(trend, "UNIT_OFFSET_MEAN", {})
    monkeypatch.setattr(trend, "UNIT_OFFSET_SD", {})
    without = rul(plain), rul(own)
    assert with_fleet[1] == without[1]        # the unit's own offset only
    assert with_fleet[0] != without[0]        # the estimators keep the fleet's


def test_commissioning_holds_each_bit_out_once_for_the_detector_and_the_wear_reading(
        bench: Bench, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`mapr commission` reads every commissioning BIT against the discrepancy relearned
    without it for the detector and again for the wear reading's scatter: the relearned
    discrepancies are made once (its slow part), and both steps still land in the record."""
    from mapr_daemon.reasoner.commissioning import detector, discrepancy, wear, workflow
    from mapr_daemon.reasoner.commissioning.prior import load_tolerances

    calls: list[int] = []
    made = discrepancy.held_out_discrepancies

    def counted(*args: object) -> list[Discrepancy]:
        calls.append(1)
        return made(*args)  # type: ignore[arg-type]

    for module in (discrepancy, detector, wear):
        monkeypatch.setattr(module, "held_out_discrepancies", counted)
    (tmp_path / "tol.yaml").write_text("format: mapr-tolerances/1\nparameters:\n"
                                       "  motor.back_emf_v_s_per_rad: 5\n")
    own = bench.runs.n - len(HELD_OUT)
    healthy = [i for i in range(own) if bench.runs.labels[i] == "healthy"][:5]
    said: list[str] = []
    done = workflow.commission(bench.params, "sheet.yaml", from_runs(bench.runs, "bench",
                                                                     healthy),
                               load_tolerances(tmp_path / "tol.yaml", bench.params),
                               tmp_path / "unit", None, said.append)
    assert len(done.identification.bits) == 5
    assert len(calls) == 1
    assert done.record.detector is not None and done.record.wear is not None
    assert any(line.startswith("anomaly detector calibrated on 5") for line in said)
    assert any(line.startswith("wear read against the baseline on 5") for line in said)
