"""An open inverter switch on a unit that is not the model's twin is named as the open switch.

The unit here departs from its data sheet in model form (voltage-mode position loop and
stiction): with a switch open its surface stalls where the model's does not, the position
residual outweighs everything else and no hypothesis leaves less than 90 % of the "no fault"
cost; before the phase currents were read, such a BIT went to the dictionary or was called
unexplained. The commissioned baseline here is the data sheet's model plus a discrepancy learned
on the unit's own healthy BITs (no identification: a few seconds).
"""

from __future__ import annotations

import numpy as np
import pytest

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.bits import BitRecord, from_runs
from mapr_daemon.reasoner.commissioning.conduction import open_switch
from mapr_daemon.reasoner.commissioning.discrepancy import learn_unit
from mapr_daemon.reasoner.commissioning.severity import Reading, read
from mapr_daemon.reasoner.commissioning.unit_decision import combine, verdict
from mapr_daemon.reasoner.diagnosis.classifier import Decision
from mapr_daemon.reasoner.training.corpus import simulate_bit

FORM = ModelForm(breakaway_ratio=2.4, stribeck_speed_rad_s=7.5, voltage_mode=True)
"""A unit whose friction law and control law the data sheet's model does not carry."""
DECIMATE = 10


@pytest.fixture(scope="module")
def unit() -> tuple[ActuatorParams, Baseline, list[BitRecord]]:
    """The data sheet, the unit's baseline learned on 6 healthy BITs, and three BITs of the
    unit at 0 Pa: open B_low, open A_low, healthy."""
    p = load_actuator(default_actuator_path())
    rng = np.random.default_rng(5)
    specs = [RunSpec(p, FaultSet(), seed=100 + k, ambient_c=float(rng.uniform(-20, 40)),
                     bus_v=float(rng.uniform(24, 30)), form=FORM) for k in range(6)]
    q = [float(rng.uniform(0, 2000)) for _ in range(6)]
    for j, faults in enumerate((FaultSet.of([Fault("open", switch="B_low")]),
                                FaultSet.of([Fault("open", switch="A_low")]), FaultSet())):
        specs.append(RunSpec(p, faults, seed=200 + j, ambient_c=20.0, bus_v=28.0, form=FORM))
        q.append(0.0)
    bits = from_runs(simulate_bit(p, [], q, [], specs=specs), "test")
    disc = learn_unit(p, bits[:6], DECIMATE)
    return p, Baseline(p, p, disc), bits[6:]


def _read(unit: tuple[ActuatorParams, Baseline, list[BitRecord]], j: int) -> Reading:
    p, bl, bits = unit
    return read(p, p, bl.discrepancy, bits[j], DECIMATE)


@pytest.mark.parametrize(("j", "switch"), [(0, "B_low"), (1, "A_low")])
def test_an_open_switch_on_a_mismatched_unit_is_named_as_the_open_switch(
        unit: tuple[ActuatorParams, Baseline, list[BitRecord]], j: int, switch: str) -> None:
    r = _read(unit, j)
    # the model alone cannot fit the stall: its best leaves most of the departure ...
    assert r.least_cost > 0.5 * r.healthy_cost
    # ... yet the event names the open switch, from the phase currents
    assert (r.mode, r.switch) == ("open", switch)
    assert verdict(r) == "single"
    dictionary = Decision(True, "friction", None, 0.9, 4.0, "x", 0.9, 50.0, 1.0, {})
    dec = combine(dictionary, r, unit[1])
    assert (dec.fault, dec.switch) == ("open", switch)
    assert dec.evidence["baseline"]["phase_currents"]["open_switch"] == switch
    assert dec.evidence["disagreement"]["baseline_part"] == "inverter bridge"


def test_a_healthy_bit_of_the_same_unit_names_no_open_switch(
        unit: tuple[ActuatorParams, Baseline, list[BitRecord]]) -> None:
    r = _read(unit, 2)
    assert r.open_seen is None and r.mode != "open"
    assert r.cost == r.least_cost


def _bridge(a: float, b: float, c: float) -> dict[str, np.ndarray]:
    """Three phase currents over one BIT's length: each phase a sine of amplitude ``a``,
    ``b``, ``c`` on its positive half and 1 A on its negative half."""
    t = np.linspace(0.0, 20 * np.pi, 2920)
    out = {}
    for name, amp, shift in (("phase_a_current_a", a, 0.0), ("phase_b_current_a", b, 2.1),
                             ("phase_c_current_a", c, 4.2)):
        s = np.sin(t + shift)
        out[name] = np.where(s > 0, amp * s, s)
    return out


def test_the_phase_currents_name_an_open_switch_only_when_one_direction_is_missing() -> None:
    p = load_actuator(default_actuator_path())
    assert open_switch(p, _bridge(1.0, 1.0, 1.0)) is None                 # sound bridge
    seen = open_switch(p, _bridge(1.0, 0.02, 1.0))                        # B high side open
    assert seen is not None and seen.switch == "B_high" and seen.candidates == ("B_high",)
    assert open_switch(p, _bridge(0.02, 0.02, 0.02)) is None              # three missing
    assert open_switch(p, {k: 0.01 * v for k, v in _bridge(1.0, 0.02, 1.0).items()}) is None
    assert open_switch(p, {"phase_a_current_a": np.zeros(10)}) is None   # channels missing
