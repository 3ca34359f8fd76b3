"""An actuator commissioned after it had flown: its stored BITs were read by two paths (the
prognostic model's estimators before, the unit's baseline after, a later commissioning's
baseline after that), each reading at its own offset. The trend rebuilt from the catalog at
every restart must weigh each stored reading by the path that read it, and so give the same
health as a unit read by one path throughout."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from mapr_daemon.catalog import BitOutcome, CatalogWriter
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.findings import Health
from mapr_daemon.pipeline.trending import Trending, history_from_bits
from mapr_daemon.reasoner.prognosis import trend, wear_paths
from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel
from mapr_daemon.reasoner.training.rul_scoring import learn_prior

T0 = 1_778_300_000_000_000_000
DAY = 24 * 3_600_000_000_000
KIND = "capacitance"   # no fleet unit offset, no fixed amplitude: the paths differ by offset
SD = 0.0625
OFFSETS = {"A": 0.375, "B": 0.125}
"""Two commissionings of the unit: each baseline reads the healthy unit at its own offset
(the estimators at 0). Binary fractions, so every reading minus its offset is exact."""
PHASES = (("estimators", range(1, 9)), ("A", range(9, 15)), ("B", range(15, 21)))


@pytest.fixture(scope="module")
def estimators() -> PrognosticModel:
    """The capacitance estimators' noise (sd 0.0625, offset 0, gain 1) and the fleet prior."""
    params = load_actuator(default_actuator_path())
    return PrognosticModel(params.name, {}, {KIND: trend.Noise(SD)}, {},
                           {KIND: learn_prior(params, KIND, 8)})


def commissioned(model: PrognosticModel, record: str) -> PrognosticModel:
    """The model of the asset commissioned with record ``record``."""
    return model.against_baseline({KIND: trend.Noise(SD, 0.0, OFFSETS[record], 1.0)})


def truth(flight: int, e: float) -> float:
    """The unit's capacitance wear at ``flight`` plus a reading error ``e``, on 1/1024."""
    return round((0.1 * (math.exp(0.06 * flight) - 1.0) + e) * 1024.0) / 1024.0


def outcome(flight: int, reading: float, path: str) -> BitOutcome:
    """One BIT as the pipeline hands it on: the reading and the path that read it."""
    if path == "estimators":
        value, source = reading, wear_paths.estimator()
    else:
        noise = trend.Noise(SD, 0.0, OFFSETS[path], 1.0)
        value, source = reading + OFFSETS[path], wear_paths.baseline(f"record-{path}", noise)
    return BitOutcome("EMA1", T0 + flight * DAY, wear={KIND: value},
                      wear_source={KIND: source})


def one_path(estimators: PrognosticModel, readings: Mapping[int, float]) -> dict[int, Health]:
    """The health after each BIT of a unit read by baseline B throughout (in memory)."""
    trending = Trending("N101", 900.0, {"EMA1": commissioned(estimators, "B")})
    out = {}
    for flight, reading in readings.items():
        trending.log.declare(flight)
        (o,) = trending.annotate([outcome(flight, reading, "B")])
        assert o.health is not None
        out[flight] = o.health
    return out


def figures(h: Health, kind: str = KIND) -> tuple[Any, ...]:
    """What ``mapr health`` shows of one kind: SoH, leading mode, the kind's h, z and RUL."""
    row = h.modes[kind]
    return (h.soh, h.mode, row["h"], row["z"], row.get("rul"), row.get("low"),
            row.get("high"))


def test_a_unit_commissioned_after_it_flew_resumes_with_each_reading_weighed_by_its_path(
        estimators: PrognosticModel, tmp_path: Path) -> None:
    rng = np.random.default_rng(20261128)
    readings = {f: truth(f, SD * float(rng.standard_normal()))
                for _, flights in PHASES for f in flights}
    path = tmp_path / "c.sqlite"
    got: dict[int, Health] = {}
    for phase, flights in PHASES:   # a restart at each: the config's path changes
        model = estimators if phase == "estimators" else commissioned(estimators, phase)
        with CatalogWriter(path) as writer:
            writer.open_session(backend="chapter10", config_hash=phase)
            bits, known, _ = writer.history("N101")
            trending = Trending("N101", 900.0, {"EMA1": model}, history_from_bits(bits),
                                known)
            for f in flights:
                trending.log.declare(f)
                out = trending.annotate([outcome(f, readings[f], phase)])
                writer.add_bits(out, trending.log.pop_changed())
                assert out[0].health is not None
                got[f] = out[0].health
    expected = one_path(estimators, readings)
    for f in range(9, 21):   # every BIT since the unit was first commissioned
        assert figures(got[f]) == figures(expected[f]), f
    assert got[20].modes[KIND].get("rul") is not None   # a trend was fitted, not skipped


def test_the_stored_sources_come_back_and_an_unknown_one_is_the_assets_path_now(
        estimators: PrognosticModel, tmp_path: Path) -> None:
    """What the catalog gives back is what the pipeline stored; a BIT without a stored
    source (written before the catalog kept it) is weighed as the asset's path now."""
    path = tmp_path / "c.sqlite"
    trending = Trending("N101", 900.0, {"EMA1": estimators})
    with CatalogWriter(path) as writer:
        writer.open_session(backend="chapter10", config_hash="x")
        for f, phase in ((1, "estimators"), (2, "A")):
            trending.log.declare(f)
            writer.add_bits(trending.annotate([outcome(f, 0.25, phase)]),
                            trending.log.pop_changed())
        trending.log.declare(3)
        writer.add_bits(trending.annotate([dataclasses.replace(
            outcome(3, 0.25, "estimators"), wear_source={})]), trending.log.pop_changed())
        bits, _, _ = writer.history("N101")
    assert [dict(b.wear_source) for b in bits] == [
        {KIND: {"path": "estimator"}},
        {KIND: {"path": "baseline", "record": "record-A", "offset": 0.375, "sd0": SD,
                "sd1": 0.0}},
        {}]
    history = history_from_bits(bits)["EMA1"]
    model = commissioned(estimators, "B")
    paths = model.path_noise(KIND, history.sources)
    est = np.array([w[KIND] for w in history.wear])
    assert paths.calibrate(est).tolist() == [0.25, 0.25, 0.25 - OFFSETS["B"]]
    assert paths.own == (False, True, True)


def test_the_fleets_unit_offset_is_put_on_the_estimators_readings_only(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """ESR's estimators read every unit low by the fleet's offset (trend.UNIT_OFFSET_MEAN); a
    reading against the unit's baseline has its own offset subtracted instead. An ESR unit
    read by the estimators, then by its baseline, trends as one read by the baseline
    throughout: the fleet's offset is taken off the estimators' readings and nothing else."""
    from mapr_daemon.reasoner.prognosis.assessment import assess

    monkeypatch.setattr(trend, "UNIT_OFFSET_MEAN", {"esr": -0.03125})   # held fixed (sd 0)
    monkeypatch.setattr(trend, "UNIT_OFFSET_SD", {})
    estimators = PrognosticModel("EMA", {}, {"esr": trend.Noise(SD)}, {}, {})
    own = trend.Noise(SD, 0.0, OFFSETS["A"], 1.0)
    model = estimators.against_baseline({"esr": own})
    rng = np.random.default_rng(7)
    flights = [float(f) for f in range(1, 21)]
    true = [round((0.03 * (f - 1) + SD * float(rng.standard_normal())) * 1024) / 1024
            for f in flights]
    mixed = [{"esr": h - 0.03125} for h in true[:10]] + \
        [{"esr": h + OFFSETS["A"]} for h in true[10:]]
    sources = [{"esr": wear_paths.estimator()}] * 10 + \
        [{"esr": wear_paths.baseline("A", own)}] * 10
    one = [{"esr": h + OFFSETS["A"]} for h in true]
    got = assess(model, flights, mixed, diagnosed="esr", seed=1, sources=sources)
    expected = assess(model, flights, one, diagnosed="esr", seed=1)
    assert figures(got, "esr") == figures(expected, "esr")
    assert got.modes["esr"].get("rul") is not None
    # read as the baseline's, the estimators' readings would sit 0.4 low: another trend
    assert figures(assess(model, flights, mixed, diagnosed="esr", seed=1), "esr") != \
        figures(expected, "esr")
