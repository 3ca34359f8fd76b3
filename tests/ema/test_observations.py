"""The seven "system reaction" observations of the paper's Table 1, plus friction.

One batch (every fault integrated together) flies the four-corner BIT profile at the cruise
condition from a cold start; each test reads its runs out of it. Magnitudes are checked as
directions and ratios against the healthy run of the same seed, not as tuned numbers.
"""

from __future__ import annotations

import numpy as np
import pytest

from mapr_daemon.arrays import FloatArray
from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.ema.run import RunResult, run_batch
from mapr_daemon.testbed.profiles import bit_profile

FAULTS: dict[str, FaultSet] = {
    "healthy": FaultSet(),
    "c144": FaultSet.of([Fault("capacitance", 144e-6)]),
    "c29": FaultSet.of([Fault("capacitance", 29e-6)]),
    "c0": FaultSet.of([Fault("capacitance", 0.0)]),
    "esr0.25": FaultSet.of([Fault("esr", 0.25)]),
    "esr0.5": FaultSet.of([Fault("esr", 0.5)]),
    "esr1": FaultSet.of([Fault("esr", 1.0)]),
    "hi1": FaultSet.of([Fault("smps_ron_high", 1.0)]),
    "hi2": FaultSet.of([Fault("smps_ron_high", 2.0)]),
    "lo2": FaultSet.of([Fault("smps_ron_low", 2.0)]),
    "inv0.18": FaultSet.of([Fault("inverter_ron_a_high", 0.18)]),
    "inv0.36": FaultSet.of([Fault("inverter_ron_a_high", 0.36)]),
    "short": FaultSet.of([Fault("short", switch="A_high")]),
    "open": FaultSet.of([Fault("open", switch="A_high")]),
    "fric3": FaultSet.of([Fault("friction", 3.0)]),
    "fric5": FaultSet.of([Fault("friction", 5.0)]),
    "compound": FaultSet.of([Fault("esr", 0.5), Fault("friction", 3.0)]),
}


@pytest.fixture(scope="module")
def result() -> RunResult:
    params = load_actuator(default_actuator_path())
    profile = bit_profile(params.sensors.sample_rate_hz, "cruise", hold_s=0.25, lead_s=0.1)
    specs = [RunSpec(params, f, seed=7) for f in FAULTS.values()]
    return run_batch(specs, profile, powered=False)


def sig(res: RunResult, name: str, fault: str, truth: bool = False) -> FloatArray:
    row = list(FAULTS).index(fault)
    return (res.truth if truth else res.channels)[name][row]


def settle_time(res: RunResult, fault: str, band: float = 0.02) -> float:
    """Time after which the DC bus stays within +/- band of 24 V, before the first corner."""
    t = res.time_s
    v = sig(res, "dc_bus_voltage_v", fault)
    before = t < res.profile.corners_s[0]
    out = np.flatnonzero(before & (np.abs(v - 24.0) > 24.0 * band))
    return float(t[out[-1]]) if out.size else 0.0


def window(res: RunResult, start: float, stop: float) -> np.ndarray:
    return (res.time_s > start) & (res.time_s < stop)


def ramp_up(res: RunResult) -> np.ndarray:
    c = res.profile.corners_s
    return window(res, c[0], c[1] + 0.02)


def test_1_less_capacitance_slower_start_and_less_impulse_headroom(result: RunResult) -> None:
    times = [settle_time(result, f) for f in ("healthy", "c144", "c29", "c0")]
    assert times == sorted(times)
    assert times[-1] > 5 * times[0]  # the loop loses its margin: no settling at the range end
    # the inverter's impulse at the first corner is carried by less charge: the DC link sags
    dip = {f: float(sig(result, "dc_bus_voltage_v", f)[ramp_up(result)].min())
           for f in ("healthy", "c144", "c29", "c0")}
    assert dip["healthy"] >= dip["c144"] - 0.02 > dip["c29"] > dip["c0"]


def test_2_more_esr_more_ripple(result: RunResult) -> None:
    steady = window(result, 0.05, result.time_s[-1])
    ripple = [float(sig(result, "ripple_rms_v", f)[steady].mean())
              for f in ("healthy", "esr0.25", "esr0.5", "esr1")]
    assert ripple == sorted(ripple)
    assert ripple[-1] > 3 * ripple[0]


def test_3_high_side_ron_output_instability(result: RunResult) -> None:
    steady = window(result, 0.05, result.time_s[-1])
    spread = [float(sig(result, "dc_bus_voltage_v", f)[steady].std())
              for f in ("healthy", "hi1", "hi2")]
    assert spread == sorted(spread)
    assert spread[-1] > 3 * spread[0]


def test_4_low_side_ron_same_sign_but_nearly_invisible(result: RunResult) -> None:
    steady = window(result, 0.05, result.time_s[-1])
    sd = {f: float(sig(result, "dc_bus_voltage_v", f)[steady].std())
          for f in ("healthy", "lo2", "hi2")}
    assert sd["lo2"] >= sd["healthy"] * 0.98
    # conducts 1 - D ~ 14 % of the time: a tenfold Ron moves the output far less than high side
    assert sd["lo2"] - sd["healthy"] < 0.25 * (sd["hi2"] - sd["healthy"])


def test_5_inverter_phase_a_ron_less_current_worse_tracking(result: RunResult) -> None:
    w = ramp_up(result)
    cmd = result.profile.command_deg
    current, error = [], []
    for f in ("healthy", "inv0.18", "inv0.36"):
        current.append(float(np.maximum(sig(result, "phase_a_current_a", f)[w], 0).mean()))
        err = sig(result, "position_true_deg", f, truth=True) - cmd
        error.append(float(np.sqrt(np.mean(err[w] ** 2))))
    assert current == sorted(current, reverse=True) and current[-1] < current[0]
    assert error == sorted(error) and error[-1] > error[0]


def test_6_short_large_current_and_position_instability(result: RunResult) -> None:
    steady = window(result, 0.05, result.time_s[-1])
    i_h = np.abs(sig(result, "dc_link_current_a", "healthy")[steady]).mean()
    i_s = np.abs(sig(result, "dc_link_current_a", "short")[steady]).mean()
    assert i_s > 10 * i_h and i_s > 5.0
    cmd = result.profile.command_deg
    e_h = np.abs(sig(result, "position_deg", "healthy") - cmd)[steady].mean()
    e_s = np.abs(sig(result, "position_deg", "short") - cmd)[steady].mean()
    assert e_s > 3 * e_h


def test_7_open_no_current_in_winding_and_position_instability(result: RunResult) -> None:
    w = ramp_up(result)
    pos_h = np.maximum(sig(result, "phase_a_current_a", "healthy")[w], 0).mean()
    pos_o = np.maximum(sig(result, "phase_a_current_a", "open")[w], 0).mean()
    assert pos_o < 0.3 * pos_h  # the open high side cannot source phase A
    cmd = result.profile.command_deg
    e_h = np.sqrt(np.mean((sig(result, "position_true_deg", "healthy", True) - cmd)[w] ** 2))
    e_o = np.sqrt(np.mean((sig(result, "position_true_deg", "open", True) - cmd)[w] ** 2))
    assert e_o > 1.1 * e_h


def test_friction_more_current_for_same_motion(result: RunResult) -> None:
    moving = window(result, result.profile.corners_s[0], result.profile.corners_s[1] + 0.05)
    peak = [float(sig(result, "dc_link_current_a", f)[moving].max())
            for f in ("healthy", "fric3", "fric5")]
    assert peak == sorted(peak) and peak[-1] > 1.1 * peak[0]
    travel = [float(sig(result, "position_deg", f)[moving][-1]) for f in ("healthy", "fric5")]
    assert abs(travel[0] - travel[1]) < 1.0  # the same motion


def test_compound_fault_shows_both_signatures(result: RunResult) -> None:
    steady = window(result, 0.05, result.time_s[-1])
    ripple = {f: sig(result, "ripple_rms_v", f)[steady].mean() for f in ("healthy", "compound")}
    assert ripple["compound"] > 2 * ripple["healthy"]
    moving = window(result, result.profile.corners_s[0], result.profile.corners_s[1] + 0.05)
    assert (sig(result, "dc_link_current_a", "compound")[moving].max()
            > sig(result, "dc_link_current_a", "healthy")[moving].max())
