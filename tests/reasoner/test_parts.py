"""Isolation to the replaceable part: the parts table, the event's part and ambiguity group
with its members' probabilities, and the bench's part-level scoring."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mapr_daemon.ema.faults import PARAMETRIC, TERMINAL, FaultSet, at_severity
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.findings import Diagnosis
from mapr_daemon.reasoner.diagnosis import parts
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary, DictionarySpec
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training import dictionary_build
from mapr_daemon.reasoner.training.corpus import Runs, simulate_bit

SPEC = DictionarySpec(
    pressures_pa=(0.0, 800.0, 1600.0), nominal_per_pressure=4, severities=(0.25, 0.5, 0.75, 1.0),
    kinds=("capacitance", "esr", "smps_ron_high", "smps_ron_low"), shorts=(), opens=(),
    seeds_per_point=2, healthy_runs=60, calibration_runs=12, record_pool=3,
    calibration_pressure_pa=(200.0, 1400.0), subspace_dims=8, knots=(0.0, 0.5, 1.0))
"""A small dictionary with both SMPS switch modes and both capacitor modes."""

HELD_OUT = [("smps_ron_low", 0.6, 900.0), ("smps_ron_low", 0.9, 400.0),
            ("capacitance", 0.7, 1100.0), ("esr", 0.5, 1300.0)]


@dataclasses.dataclass
class Smps:
    params: ActuatorParams
    dictionary: Dictionary
    held: Runs


@pytest.fixture(scope="module")
def smps() -> Smps:
    params = load_actuator(default_actuator_path())
    plan = dictionary_build._plan(params, SPEC)
    fs, qs, seeds, roles = plan.faults, plan.pressures_pa, plan.seeds, plan.roles
    n_own = len(fs)
    fs += [FaultSet.of([at_severity(params, k, s)]) for k, s, _ in HELD_OUT]
    qs += [q for _, _, q in HELD_OUT]
    seeds += [60_000 + i for i in range(len(HELD_OUT))]
    runs = simulate_bit(params, fs, qs, seeds)
    starts = dictionary_build.windows(SPEC, runs.corners, runs.command_deg.size)
    m = dictionary_build.run_matrices(runs, starts, SPEC.window_samples)
    d = dictionary_build.assemble(params, SPEC, m[:n_own], runs.dynamic_pressure_pa[:n_own], roles,
                       starts, runs.sample_rate_hz)
    held = dataclasses.replace(runs, channels={k: v[n_own:] for k, v in runs.channels.items()},
                               dynamic_pressure_pa=runs.dynamic_pressure_pa[n_own:])
    return Smps(params, d, held)


def _event(s: Smps, i: int) -> Diagnosis:
    ch = {k: v[i] for k, v in s.held.channels.items()}
    return Reasoner(s.dictionary, s.params).diagnose(ch, s.held.command_deg,
                                                     float(s.held.dynamic_pressure_pa[i]))


def test_every_fault_mode_belongs_to_one_part() -> None:
    modes = set(PARAMETRIC) | set(TERMINAL)
    assert set(parts.PART_OF) == set(parts.COMPONENTS) == modes
    assert sum(len(p.members) for p in parts.PARTS) == len(modes)
    assert parts.PART_OF["smps_ron_high"] == parts.PART_OF["smps_ron_low"] == "SMPS switches"


@pytest.mark.parametrize("i", [0, 1])
def test_a_low_side_ron_event_names_the_switch_pair_and_both_members(smps: Smps, i: int) -> None:
    e = _event(smps, i)
    assert e.anomaly is True and e.part == "SMPS switches"
    amb = e.ambiguity
    assert isinstance(amb, dict) and amb["part"] == "SMPS switches"
    probs = {m["fault"]: m["probability"] for m in amb["members"]}
    assert set(probs) == {"smps_ron_high", "smps_ron_low"}
    assert all(0.0 <= p <= 1.0 for p in probs.values())
    assert sum(probs.values()) == pytest.approx(1.0, abs=2e-4)
    assert e.fault == amb["members"][0]["fault"]  # the event names the most probable
    assert amb["group"] == [m for m, p in sorted(probs.items(), key=lambda kv: -kv[1])
                            if p >= parts.NEGLIGIBLE]
    assert amb["ambiguous"] == (len(amb["group"]) > 1)
    assert e.component == parts.COMPONENTS[str(e.fault)]


def test_a_capacitance_event_states_no_ambiguity(smps: Smps) -> None:
    e = _event(smps, 2)
    assert e.fault == "capacitance" and e.part == "SMPS output capacitor"
    amb = e.ambiguity
    assert isinstance(amb, dict)
    assert amb["group"] == ["capacitance"] and amb["ambiguous"] is False
    assert [m["fault"] for m in amb["members"]] == ["capacitance", "esr"]
    assert all(0.0 <= m["probability"] <= 1.0 for m in amb["members"])


def test_probabilities_follow_the_residuals() -> None:
    p = parts.mode_probabilities({"smps_ron_high": 10.0, "smps_ron_low": 10.0 + 2 * np.log(3),
                                  "esr": 80.0}, scale=1.0)
    assert p["smps_ron_high"] == pytest.approx(0.75, abs=1e-6)
    assert p["smps_ron_low"] == pytest.approx(0.25, abs=1e-6)
    assert p["esr"] < 1e-12
    wider = parts.mode_probabilities({"smps_ron_high": 10.0, "smps_ron_low": 14.0}, scale=2.0)
    assert wider["smps_ron_low"] == pytest.approx(1 / (1 + np.e))
    assert parts.ambiguity(None, {"esr": 1.0}, 1.0) is None


def test_part_scoring_counts_a_high_low_confusion_as_isolated() -> None:
    tally = parts.Isolation()
    amb = parts.ambiguity("smps_ron_high", {"smps_ron_high": 10.0, "smps_ron_low": 11.0,
                                             "capacitance": 90.0}, 1.0)
    tally.add("smps_ron_low", "smps_ron_high", amb)       # confused within the part
    tally.add("capacitance", "smps_ron_high", amb)        # another part
    tally.add("esr", None, None)                          # not detected
    tally.add("friction", "friction", None)               # right, nothing to weigh
    assert (tally.runs, tally.part, tally.member, tally.in_group) == (4, 2, 1, 2)
    assert tally.p_true[0] == pytest.approx(1 / (1 + np.exp(0.5)), abs=1e-4)
    assert tally.p_true[1:] == [0.0, 0.0, 1.0]
    assert parts.same_part("smps_ron_low", "smps_ron_high")
    assert not parts.same_part("smps_ron_low", "capacitance")
    assert not parts.same_part("esr", None)
