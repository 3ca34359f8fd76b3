"""The compiled plant step (:mod:`mapr_daemon.ema.step`) against recorded reference runs.

``tests/data/ema/reference_runs.npz`` was recorded from the plant's numpy implementation
(vectorised across runs, one numpy call per operation) before the step was compiled; that
implementation and a plain-float one agreed to rounding, and the compiled step reproduced the
float one bit for bit on every fault kind at several magnitudes, compound faults, the BIT
profile and JSBSim flights. For the healthy actuator, every fault kind and a compound fault,
over a cold-start BIT move and a powered JSBSim segment (the profiles are stored with the
references, so the test does not depend on JSBSim's version), the file keeps each signal's
means over 40 equal windows and its whole-run standard deviation. The compiled step must give:

* noise-free signals (``truth``): window means within 1e-9 relative plus 1e-9 absolute;
* sensor channels: window means and standard deviations within one ADC LSB (the noise is the
  same for the same seed; quantisation can move by one LSB where the signal sits on a step).

Three knife-edge runs (a dead output capacitor at start-up, a phase an open low-side switch
leaves floating on the diode threshold, a short plus an open on two phases) decide diode
events on exact comparisons, so last-bit rounding differences between implementations can
change their trajectories; they are compared by each channel's mean and standard deviation
(within 2 % of full scale).

When the model's physics is changed on purpose, record new references with
``python3 tests/ema/test_step.py --record`` and say why in the commit.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema import inverter, step
from mapr_daemon.ema.batch import RunSpec, build
from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.ema.params import (
    CHANNELS,
    CONTROLLER_CHANNELS,
    default_actuator_path,
    load_actuator,
)
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.testbed.profiles import Profile, bit_profile
from mapr_daemon.testbed.profiles_jsbsim import jsbsim_flight

PARAMS = load_actuator(default_actuator_path())
REFERENCE = Path(__file__).parents[1] / "data" / "ema" / "reference_runs.npz"
FAULTS: dict[str, FaultSet] = {
    "healthy": FaultSet(),
    "capacitance": FaultSet.of([Fault("capacitance", 72e-6)]),
    "esr": FaultSet.of([Fault("esr", 1.0)]),
    "smps_ron_high": FaultSet.of([Fault("smps_ron_high", 2.0)]),
    "smps_ron_low": FaultSet.of([Fault("smps_ron_low", 2.0)]),
    "inverter_ron_a_high": FaultSet.of([Fault("inverter_ron_a_high", 0.36)]),
    "friction": FaultSet.of([Fault("friction", 5.0)]),
    "short": FaultSet.of([Fault("short", switch="A_high")]),
    "open": FaultSet.of([Fault("open", switch="A_high")]),
    "compound": FaultSet.of([Fault("esr", 0.5), Fault("short", switch="C_low")]),
}
KNIFE_EDGE: dict[str, FaultSet] = {
    "capacitance_dead": FaultSet.of([Fault("capacitance", 0.0)]),
    "open_b_low": FaultSet.of([Fault("open", switch="B_low")]),
    "multi_switch": FaultSet.of([Fault("short", switch="A_high"), Fault("open", switch="B_high"),
                                 Fault("smps_ron_low", 0.9), Fault("capacitance", 100e-6)]),
}
ALL = {**FAULTS, **KNIFE_EDGE}
WINDOWS = 40
RECORDED = CHANNELS + CONTROLLER_CHANNELS
"""The channels the reference file holds (the switch temperatures came after it; they have
their own tests, tests/ema/test_switch_temperatures.py)."""
PROFILES = ("bit", "jsbsim")


def specs() -> list[RunSpec]:
    return [RunSpec(PARAMS, f, seed=10 + k) for k, f in enumerate(ALL.values())]


def new_profiles() -> dict[str, tuple[Profile, bool]]:
    """The profiles the references were recorded on (and whether the run starts powered)."""
    rate = PARAMS.sensors.sample_rate_hz
    return {"bit": (bit_profile(rate, "cruise", hold_s=0.12, lead_s=0.04), False),
            "jsbsim": (jsbsim_flight(rate, "cruise", duration_s=0.4, seed=2), True)}


def summary(signals: dict[str, FloatArray]) -> dict[str, FloatArray]:
    """Window means ``(runs, WINDOWS)`` and standard deviations ``(runs,)`` of each signal."""
    out = {}
    for name, x in signals.items():
        n = x.shape[1] // WINDOWS * WINDOWS
        out[f"{name}/mean"] = x[:, :n].reshape(x.shape[0], WINDOWS, -1).mean(axis=2)
        out[f"{name}/std"] = x.std(axis=1)
    return out


def simulate(command_deg: FloatArray, q: FloatArray, powered: bool) -> dict[str, FloatArray]:
    block = EmaBatch(specs(), powered=powered).advance(command_deg.size, command_deg, q)
    out = {f"ch/{k}": v for k, v in summary(
        {k: block.channels[k] for k in RECORDED}).items()}
    out.update({f"truth/{k}": v for k, v in summary(block.truth).items()})
    return out


def record(path: Path) -> None:
    """Write the reference file from the current model."""
    arrays: dict[str, FloatArray] = {}
    for name, (prof, powered) in new_profiles().items():
        arrays[f"{name}/command_deg"] = prof.command_deg
        arrays[f"{name}/dynamic_pressure_pa"] = prof.dynamic_pressure_pa
        arrays[f"{name}/powered"] = np.array(float(powered))
        for key, value in simulate(prof.command_deg, prof.dynamic_pressure_pa, powered).items():
            arrays[f"{name}/{key}"] = value
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **arrays)  # type: ignore[arg-type]


def lsb(name: str) -> float:
    if name == "commutation_sector":
        return 0.0
    if name == "inverter_duty":
        return PARAMS.sensors.sample_rate_hz / (PARAMS.inverter.pwm_counter_period
                                                * PARAMS.inverter.pwm_frequency_hz)
    spec = PARAMS.sensors.channels[name]
    return float(2.0 * spec.full_scale / 2.0**spec.bits)


def full_scale(name: str) -> float:
    if name in PARAMS.sensors.channels:
        return PARAMS.sensors.channels[name].full_scale
    return 6.0 if name == "commutation_sector" else 1.0


@pytest.fixture(scope="module", params=PROFILES)
def runs(request: pytest.FixtureRequest) -> tuple[dict[str, FloatArray], dict[str, FloatArray]]:
    """(reference, compiled step) summaries of one profile."""
    name = request.param
    with np.load(REFERENCE) as data:
        ref = {k[len(name) + 1:]: data[k] for k in data.files if k.startswith(f"{name}/")}
    got = simulate(ref["command_deg"], ref["dynamic_pressure_pa"], bool(ref["powered"]))
    return ref, got


def test_strict_runs_match_the_reference(
        runs: tuple[dict[str, FloatArray], dict[str, FloatArray]]) -> None:
    ref, got = runs
    strict = len(FAULTS)
    for key, value in got.items():
        kind, name, _ = key.split("/")
        a, b = value[:strict], ref[key][:strict]
        if kind == "truth":
            close = np.isclose(a, b, rtol=1e-9, atol=1e-9)
            assert close.all(), f"{key}: runs {np.flatnonzero(~close.reshape(strict, -1).all(1))}"
        else:
            worst = np.abs(a - b).reshape(strict, -1).max(axis=1)
            bad = [f for f, w in zip(FAULTS, worst, strict=True) if w > lsb(name) * 1.001]
            assert not bad, f"{key}: {bad}"


def test_knife_edge_runs_match_the_reference_statistics(
        runs: tuple[dict[str, FloatArray], dict[str, FloatArray]]) -> None:
    ref, got = runs
    for name in RECORDED:
        for stat in ("mean", "std"):
            key = f"ch/{name}/{stat}"
            a, b = got[key][len(FAULTS):], ref[key][len(FAULTS):]
            if stat == "mean":
                a, b = a.mean(axis=1), b.mean(axis=1)
            assert (np.abs(a - b) <= 0.02 * full_scale(name)).all(), key


def test_chunking_and_batch_neighbours_do_not_change_a_run() -> None:
    runs = specs()[:1] + specs()[7:8]  # healthy, shorted A_high
    cmd = np.linspace(0, 12, 30)
    whole = EmaBatch(runs).advance(30, cmd, 1200.0)
    b = EmaBatch(runs)
    parts = [b.advance(n, cmd[k:k + n], 1200.0) for k, n in ((0, 7), (7, 1), (8, 22))]
    alone = EmaBatch(runs[1:]).advance(30, cmd, 1200.0)
    for name, values in {**whole.channels, **whole.truth}.items():
        joined = np.concatenate([(x.channels | x.truth)[name] for x in parts], axis=1)
        np.testing.assert_array_equal(values, joined)
        np.testing.assert_array_equal(values[1:], (alone.channels | alone.truth)[name])
    np.testing.assert_array_equal(whole.time_s, np.concatenate([x.time_s for x in parts]))


def test_inputs_of_any_shape_reuse_one_compiled_kernel() -> None:
    """Scalars, per-sample and per-run inputs, one run or one sample: one kernel signature
    (a read-only or strided argument would be a new numba type, compiled again)."""
    EmaBatch(specs()[:2]).advance(4, 1.0, 500.0)
    before = set(step.integrate.signatures)
    one = EmaBatch(specs()[:1])
    one.advance(5, np.linspace(0.0, 1.0, 5), np.full(5, 800.0))
    one.advance(1, 0.0, 500.0)
    two = EmaBatch(specs()[:2])
    two.advance(3, 0.0, np.full((2, 3), 700.0), ambient_c=np.array([10.0, 20.0]))
    two.advance(1, np.array([1.0, 2.0]), 300.0)
    assert set(step.integrate.signatures) == before


def test_parameter_and_state_layout() -> None:
    for k, name in enumerate(step.PAR):
        column = name.upper()
        if name[-2:] in ("_b", "_c"):
            continue  # phases B and C follow phase A's column
        assert getattr(step, column) == k, name
    p = build(specs()[:2])
    par = step.pack(p, np.array([1.0, 2.0]), np.array([3.0, 4.0]), np.array([5.0, 6.0]))
    assert par.shape == (2, len(step.PAR))
    for name in step.SCALARS:
        np.testing.assert_array_equal(par[:, step.PAR.index(name)], getattr(p, name))
    for name in step.PHASED:
        for ph, letter in enumerate("abc"):
            np.testing.assert_array_equal(par[:, step.PAR.index(f"{name}_{letter}")],
                                          getattr(p, name)[ph])
    np.testing.assert_array_equal(par[:, step.BUS_OFFSET], [5.0, 6.0])
    # the step's commutation tables are the inverter's geometry
    assert tuple(int(i) for i in inverter.POSITIVE.argmax(axis=1)) == step.PLUS
    assert tuple(int(i) for i in inverter.NEGATIVE.argmax(axis=1)) == step.MINUS
    assert all({a, b, c} == {0, 1, 2} for a, b, c in zip(step.PLUS, step.MINUS, step.IDLE,
                                                         strict=True))


if __name__ == "__main__":
    if sys.argv[1:] != ["--record"]:
        sys.exit("usage: python3 tests/ema/test_step.py --record")
    record(REFERENCE)
    print(f"wrote {REFERENCE}")
