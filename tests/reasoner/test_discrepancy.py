"""The learned discrepancy on a unit our model cannot express (a housekeeping load on the
supply and sensor offsets: an explicit model form, the rest of the unit the data sheet's), and
a faulted BIT's mode and severity read against that unit's baseline.

One module-level batch: six healthy BITs to learn from and three held-out healthy BITs, at
different conditions above the supply floor, plus one faulted BIT (the severity test). The
model is the data sheet itself (no identification: it would not express the load either), so
the test stays at seconds."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning import discrepancy as dsc
from mapr_daemon.reasoner.commissioning import severity
from mapr_daemon.reasoner.commissioning.bits import FIT_SIGNALS, BitRecord, from_runs
from mapr_daemon.reasoner.commissioning.flight import noise_scale
from mapr_daemon.reasoner.commissioning.record import CommissioningRecord
from mapr_daemon.reasoner.training.corpus import simulate_bit

FORM = ModelForm(housekeeping_w=2.5, sensor_offset=(("dc_link_current_a", 0.05),
                                                     ("position_deg", 0.05)))
LEARN = [(0.0, 20.0, 27.0), (800.0, -10.0, 28.5), (1600.0, 45.0, 26.5),
         (2400.0, 5.0, 28.0), (400.0, 60.0, 27.5), (2000.0, -30.0, 26.8)]
HELD = [(1200.0, 30.0, 27.3), (200.0, 0.0, 28.2), (2200.0, 50.0, 26.6)]
"""(dynamic pressure Pa, ambient C, bus V) of the BITs."""
FAULT = ("friction", 0.5, (1000.0, 15.0, 27.6))
DECIMATE = 10


@dataclasses.dataclass
class Unit:
    sheet: ActuatorParams
    learn: list[BitRecord]
    held: list[BitRecord]
    faulted: BitRecord


@pytest.fixture(scope="module")
def unit() -> Unit:
    sheet = load_actuator(default_actuator_path())
    kind, sev, fault_at = FAULT
    runs = [(FaultSet(), c) for c in LEARN + HELD] + [
        (FaultSet.of([at_severity(sheet, kind, sev)]), fault_at)]
    specs = [RunSpec(sheet, f, seed=900 + i, ambient_c=c[1], bus_v=c[2], form=FORM)
             for i, (f, c) in enumerate(runs)]
    bits = from_runs(simulate_bit(sheet, [], [c[0] for _, c in runs], [], specs=specs), "t")
    return Unit(sheet, bits[:len(LEARN)], bits[len(LEARN):-1], bits[-1])


@pytest.fixture(scope="module")
def learned(unit: Unit) -> dsc.Discrepancy:
    return dsc.learn_unit(unit.sheet, unit.learn, DECIMATE)


def _held_rms(unit: Unit, disc: dsc.Discrepancy | None) -> dict[str, float]:
    r = dsc.residuals(unit.sheet, unit.held, DECIMATE)
    if disc is not None:
        r = r - dsc.correction_for(disc, unit.sheet, unit.held)
    z = r / noise_scale(unit.sheet, DECIMATE)[None, :, None]
    return {k: float(np.sqrt(np.mean(z[:, j] ** 2))) for j, k in enumerate(FIT_SIGNALS)}


def test_discrepancy_closes_the_fit_on_held_out_bits(unit: Unit,
                                                     learned: dsc.Discrepancy) -> None:
    before, after = _held_rms(unit, None), _held_rms(unit, learned)
    # the housekeeping load shows on the supply current, the offsets on their channels
    for k in ("smps_input_current_a", "dc_link_current_a", "position_deg"):
        assert before[k] > 5.0, (k, before[k])
        assert after[k] < before[k] / 4.0, (k, before[k], after[k])
    # the record's leave-one-out figure says the same as the held-out BITs
    summary = learned.summary()["signals"]
    assert isinstance(summary, dict)
    assert summary["smps_input_current_a"]["held_out_rms_corrected"] < \
        summary["smps_input_current_a"]["held_out_rms_model"] / 4.0


def test_discrepancy_file_round_trips(unit: Unit, learned: dsc.Discrepancy,
                                      tmp_path: Path) -> None:
    learned.save(tmp_path / "d.npz")
    back = dsc.Discrepancy.load(tmp_path / "d.npz")
    a = dsc.correction_for(learned, unit.sheet, unit.held)
    b = dsc.correction_for(back, unit.sheet, unit.held)
    assert np.allclose(a, b)
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(ConfigError):
        dsc.Discrepancy.load(tmp_path / "bad.npz")


def test_too_few_bits_learn_nothing(unit: Unit) -> None:
    with pytest.raises(ConfigError, match="at least"):
        dsc.learn_unit(unit.sheet, unit.learn[:2], DECIMATE)


def test_record_without_discrepancy_still_loads() -> None:
    old: dict[str, object] = {
           "format": "mapr-commissioning/1", "created": "2025-01-01T00:00:00+00:00",
           "actuator": "a", "datasheet": "a.yaml", "identified_actuator": "actuator.yaml",
           "dictionary": None, "parameters": [], "tolerances": [],
           "residual_rms": {"before": {}, "after": {}}, "bits": [], "skipped": [],
           "correlation": [], "fit": {"iterations": 3, "converged": False,
                                      "model_runs": 10, "wall_s": 1.0}}
    rec = CommissioningRecord.from_json(json.loads(json.dumps(old)))
    assert rec.discrepancy is None and rec.converged is False
    again = CommissioningRecord.from_json(rec.to_json())
    assert again == rec


def test_fault_read_against_the_units_baseline(unit: Unit, learned: dsc.Discrepancy) -> None:
    kind, sev, _ = FAULT
    r = severity.read(unit.sheet, unit.sheet, learned, unit.faulted, DECIMATE)
    assert r.mode == kind and abs(r.severity - sev) < 0.1, r
    assert r.healthy_cost - r.cost > 1.0
    # a healthy BIT of the unit: no fault explains much of it
    h = severity.read(unit.sheet, unit.sheet, learned, unit.held[0], DECIMATE,
                      kinds=(kind, "esr"), terminal=False)
    assert h.healthy_cost - h.cost < 0.5 and h.healthy_cost < 3.0, h
