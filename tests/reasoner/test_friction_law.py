"""A unit whose motor sticks (stiction) where the data sheet's law creeps: commissioning picks
the sticking law from the unit's healthy BITs, and a friction fault on that unit is then read
as friction, at its severity, explained.

One module-level batch: six healthy BITs at different conditions above the supply floor and
one BIT with the friction factor at 60 % of its range, of a unit that is the data sheet with
stiction (breakaway twice the Coulomb torque). Only the two friction terms are identified, so
the test stays well under a minute."""

from __future__ import annotations

import dataclasses

import pytest

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.dump import dump_actuator
from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.reasoner.commissioning import discrepancy as dsc
from mapr_daemon.reasoner.commissioning import severity
from mapr_daemon.reasoner.commissioning.bits import BitRecord, from_runs
from mapr_daemon.reasoner.commissioning.friction_law import FRICTION_PATHS, identify_with_law
from mapr_daemon.reasoner.commissioning.identify import Identification, identify
from mapr_daemon.reasoner.commissioning.prior import Tolerance
from mapr_daemon.reasoner.commissioning.unit_decision import explains
from mapr_daemon.reasoner.training.corpus import simulate_bit

FORM = ModelForm(breakaway_ratio=2.0, stribeck_speed_rad_s=6.0)
LEARN = [(0.0, 20.0, 27.0), (800.0, -10.0, 28.5), (1600.0, 45.0, 26.5),
         (2400.0, 5.0, 28.0), (400.0, 60.0, 27.5), (2000.0, -30.0, 26.8)]
"""(dynamic pressure Pa, ambient C, bus V) of the healthy BITs."""
FAULT = ("friction", 0.6, (1200.0, 15.0, 27.6))
TOLERANCES = tuple(Tolerance(p, 40.0, 40.0) for p in FRICTION_PATHS)
DECIMATE = 10


@dataclasses.dataclass
class Unit:
    sheet: ActuatorParams
    learn: list[BitRecord]
    faulted: BitRecord


@pytest.fixture(scope="module")
def unit() -> Unit:
    sheet = load_actuator(default_actuator_path())
    kind, sev, fault_at = FAULT
    runs = [(FaultSet(), c) for c in LEARN] + [
        (FaultSet.of([at_severity(sheet, kind, sev)]), fault_at)]
    specs = [RunSpec(sheet, f, seed=700 + i, ambient_c=c[1], bus_v=c[2], form=FORM)
             for i, (f, c) in enumerate(runs)]
    bits = from_runs(simulate_bit(sheet, [], [c[0] for _, c in runs], [], specs=specs), "t")
    return Unit(sheet, bits[:-1], bits[-1])


@pytest.fixture(scope="module")
def fitted(unit: Unit) -> Identification:
    return identify_with_law(unit.sheet, unit.learn, TOLERANCES)


def test_the_sticking_law_is_chosen_and_written(fitted: Identification) -> None:
    assert fitted.friction_law is not None
    assert fitted.params.motor.breakaway_ratio >= 1.0, fitted.friction_law
    scores = fitted.friction_law["scores"]
    assert isinstance(scores, list)
    smooth = next(s["score"] for s in scores if s["breakaway_ratio"] == 0.0)
    assert max(s["score"] for s in scores) > smooth
    # the identified actuator file carries the law (what the baseline loads)
    assert "breakaway_ratio" in dump_actuator(fitted.params)


def test_friction_fault_on_a_sticking_unit_is_read_as_friction(
        unit: Unit, fitted: Identification) -> None:
    kind, sev, _ = FAULT
    disc = dsc.learn_unit(fitted.params, unit.learn, DECIMATE)
    r = severity.read(fitted.params, unit.sheet, disc, unit.faulted, DECIMATE)
    assert r.mode == kind, r
    assert abs(r.severity - sev) <= 0.15, r
    assert explains(r), r   # the product's default rule: leaves at most half of "no fault"


def test_without_the_choice_the_data_sheets_law_stays(unit: Unit) -> None:
    plain = identify(unit.sheet, unit.learn[:3], TOLERANCES)   # the default: not chosen
    assert plain.friction_law is None and plain.params.motor.breakaway_ratio == 0.0
