"""One health story: single-fault units of each trended mode, flown BIT by BIT.

Each unit is an aileron whose one part ages (capacitance, ESR, friction, SMPS high-side
switch) from new to 75 % of the way to its replace-at threshold over six flights, one BIT a
flight, diagnosed by the demo's shipped models (the classifier and the prognostic model's
estimators; no EKF: the wear verdicts do not use it) and trended as the daemon trends
(:class:`~mapr_daemon.pipeline.trending.Trending`). Checked:

* only the unit's own mode is ever reported wearing (``evidenced``): the other modes of its
  part, and of the parts the classifier did not name, read as its wear;
* its figures are one story: ``mapr health``, ``mapr catalog list`` and ``catalog export``
  give the same SoH and RUL, written the same way (:mod:`mapr_daemon.views.figures`), and a
  stored fault's severity says its nominal and replace-at threshold.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.catalog import BitOutcome, CatalogWriter
from mapr_daemon.catalog.model import event_from_reasoner
from mapr_daemon.ema.faults import Fault, FaultSet, nominal_value
from mapr_daemon.ema.params import default_actuator_path, load_actuator, with_sample_rate
from mapr_daemon.pipeline.trending import Trending
from mapr_daemon.reasoner.diagnosis import classifier
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.prognosis import soh
from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training.corpus import BitRuns
from mapr_daemon.reasoner.training.dictionary_build import stream_matrices
from mapr_daemon.views.figures import rul_text, soh_text
from tests.catalog.test_catalog_cli import mapr

MODELS = Path(__file__).resolve().parents[2] / "mapr_daemon" / "testbed" / "models"
WEAR = (0.0, 0.15, 0.3, 0.45, 0.6, 0.75)
"""Each unit's degradation at its six BITs (share of the way to the replace-at threshold)."""
TAIL = "N7"
HOUR_NS = 3_600_000_000_000
T0 = 1_770_000_000_000_000_000


@pytest.fixture(scope="module")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, list[BitOutcome]]]:
    """The units' BITs, diagnosed and trended, and a catalog holding them (one actuator
    per mode, named after it)."""
    d = Dictionary.load(MODELS / "dictionary-aileron-uav-2000hz.npz")
    model = PrognosticModel.load(MODELS / "prognosis-aileron-uav-2000hz.npz").with_lives()
    params = with_sample_rate(load_actuator(default_actuator_path()), 2000.0)
    reasoner = Reasoner(d, params)
    rng = np.random.default_rng(11)
    runs: list[tuple[str, int, FaultSet, float]] = []
    for kind in model.kinds:
        lo, hi = nominal_value(params, kind), soh.failure_value(params, kind)
        runs += [(kind, i, FaultSet.of([Fault(kind, lo + h * (hi - lo))]) if h else FaultSet(),
                  float(rng.uniform(300.0, 2000.0))) for i, h in enumerate(WEAR)]
    m = stream_matrices(params, BitRuns.of([r[2] for r in runs], [r[3] for r in runs],
                                           [700_000 + i for i in range(len(runs))]),
                        d.window_starts, d.window_samples)
    trending = Trending(TAIL, 900.0, {kind: model for kind in model.kinds})
    units: dict[str, list[BitOutcome]] = {}
    for j, (kind, i, _, q) in enumerate(runs):
        t = T0 + i * 3 * HOUR_NS + j * 1_000_000_000
        decision = reasoner.event(classifier.decide(d, m[j], q))
        event = None if not decision.anomaly else event_from_reasoner(decision, t_ns=t,
                                                                      asset=kind)
        trending.log.declare(i + 1, 1.5)
        outcome = BitOutcome(kind, t, event, wear=model.estimates(d, m[j], q),
                             conditions=model.bit_conditions(d, m[j], q))
        units.setdefault(kind, []).extend(trending.annotate([outcome]))
    path = tmp_path_factory.mktemp("story") / "catalog.sqlite"
    with CatalogWriter(path) as writer:
        writer.open_session(backend="test", config_hash="story", started_ns=T0)
        for kind in units:
            writer.add_bits(units[kind])
    return path, units


def test_only_the_units_own_mode_is_reported_wearing(
        fleet: tuple[Path, dict[str, list[BitOutcome]]]) -> None:
    _, units = fleet
    for kind, bits in units.items():
        wearing = {k for b in bits if b.health is not None
                   for k, row in b.health.modes.items() if row["evidenced"]}
        assert wearing <= {kind}, (kind, wearing)
        last = bits[-1].health
        assert last is not None and last.mode == kind, (kind, last)
        # at 75 % of the way to its threshold the unit's SoH says so, within the estimate's
        # scatter
        assert last.soh is not None and 0.1 < last.soh < 0.6, (kind, last.soh)


def test_health_catalog_list_and_export_tell_one_story(
        fleet: tuple[Path, dict[str, list[BitOutcome]]]) -> None:
    path, units = fleet
    health = mapr("health", "--catalog", str(path))
    assert health.returncode == 0, health.stderr
    listed = mapr("catalog", "list", "--catalog", str(path), "--limit", "0")
    assert listed.returncode == 0, listed.stderr
    exported = mapr("catalog", "export", "--what", "bits", "--format", "csv",
                    "--catalog", str(path))
    assert exported.returncode == 0, exported.stderr
    rows = list(csv.DictReader(io.StringIO(exported.stdout)))
    health_lines = {line.split()[0]: line for line in health.stdout.splitlines()[1:]}
    events = json.loads(mapr("catalog", "list", "--json", "--catalog", str(path),
                             "--limit", "0").stdout)
    for kind, bits in units.items():
        last = bits[-1].health
        assert last is not None
        line = health_lines[f"{TAIL}/{kind}"]
        # mapr health: the SoH and the RUL as figures.py writes them
        assert line.split()[1] == soh_text(last.soh)
        if last.rul is not None:
            assert rul_text(last.rul, last.rul_low, last.rul_high) in line
        # export: the same numbers, unrounded, as the health read
        mine = [r for r in rows if r["asset"] == kind]
        assert float(mine[-1]["soh"]) == pytest.approx(last.soh, abs=1e-9)
        # catalog list: each event's SoH and RUL are its BIT's health, written the same way
        by_time = {b.t_ns: b.health for b in bits if b.event is not None}
        for e in (e for e in events if e["asset"] == kind):
            h = by_time[e["t_ns"]]
            assert h is not None and e["soh"] == pytest.approx(h.soh)
            table_row = next(row for row in listed.stdout.splitlines()
                             if row.startswith(f"{e['id']} ") or row.split()[0] == str(e["id"]))
            assert f" {soh_text(h.soh)} " in f"{table_row} "
            if h.rul is not None:
                assert rul_text(h.rul, h.rul_low, h.rul_high) in table_row
            # the severity says what it is measured against
            assert "x nominal" in table_row
            assert "replace at" in table_row
