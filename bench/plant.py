"""Plant speed: simulated seconds per wall second for one actuator, and a 416-run dictionary.

Integration method: fixed 25 us steps (the SMPS 2x2 system advanced exactly per step, the
winding resistance implicitly), the whole step compiled (:mod:`mapr_daemon.ema.step`, numba
through ``drivers.jit.kernel``): Python enters once per ``advance`` chunk, and the loop over
runs, samples and steps is machine code. It reproduces the numpy and float implementations it
replaced (``tests/ema/test_step.py``). Why not scipy's compiled integrators: the plant switches
every Hall sector and diode event, so an adaptive solver would restart at each event.

The first call in a process loads the kernel from numba's on-disk cache (or compiles it, ~25 s,
after a change to the step); it is timed separately and excluded from the speeds. Speeds are
best of ``--repeat`` runs, per wall second and per CPU second of this thread (the machine is
shared: the load average is printed). Run: ``python3 bench/plant.py`` (``--quick`` times one
dictionary group and extrapolates).
"""

from __future__ import annotations

import argparse
import os
import time

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import Fault, FaultSet, at_severity
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.ema.plant import EmaBatch
from mapr_daemon.ema.run import run_batch
from mapr_daemon.testbed.profiles import Profile, bit_profile
from mapr_daemon.testbed.profiles_jsbsim import jsbsim_flight

KINDS = ("capacitance", "esr", "smps_ron_high", "smps_ron_low", "inverter_ron_a_high", "friction")
CONDITIONS = ("ground", "approach", "cruise", "dash")


def dictionary_group(p: ActuatorParams, cond_index: int) -> list[RunSpec]:
    """The 104 runs of one flight condition (as configs/profiles/dictionary-416.yaml)."""
    sets = [FaultSet(), FaultSet()]
    sets += [FaultSet.of([at_severity(p, k, s / 16)]) for k in KINDS for s in range(1, 17)]
    sets += [FaultSet.of([Fault("short", switch=w)]) for w in ("A_high", "B_high", "C_low")]
    sets += [FaultSet.of([Fault("open", switch=w)]) for w in ("A_high", "B_low", "C_high")]
    return [RunSpec(p, fs, seed=1000 * cond_index + i) for i, fs in enumerate(sets)]


def speed(params: ActuatorParams, profile: Profile, repeat: int,
          powered: bool) -> tuple[float, float]:
    """Best-of-``repeat`` simulated seconds per wall second of one actuator over ``profile``,
    and per CPU second of this thread (less sensitive to other work on a shared machine)."""
    best = best_cpu = 0.0
    for _ in range(repeat):
        plant = EmaBatch([RunSpec(params, seed=1)], powered=powered)
        t0, c0 = time.perf_counter(), time.thread_time()
        plant.advance(profile.n_samples, profile.command_deg, profile.dynamic_pressure_pa)
        wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
        best = max(best, profile.time_s[-1] / wall)
        best_cpu = max(best_cpu, profile.time_s[-1] / max(cpu, 1e-9))
    return best, best_cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    params = load_actuator(default_actuator_path())
    rate = params.sensors.sample_rate_hz
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; "
          f"step {params.sensors.step_s * 1e6:g} us, sensor rate {rate:g} Hz")
    t0 = time.perf_counter()
    EmaBatch([RunSpec(params, seed=1)]).advance(1)
    print(f"first call (kernel loaded from cache or compiled): {time.perf_counter() - t0:.2f} s")
    bit = bit_profile(rate, "cruise")
    flight = jsbsim_flight(rate, "cruise", duration_s=30.0, seed=1)
    for name, prof, powered in ((f"BIT {bit.time_s[-1]:.2f} s", bit, False),
                                (f"JSBSim cruise {flight.time_s[-1]:.0f} s", flight, True)):
        sca, cpu = speed(params, prof, args.repeat, powered)
        print(f"one actuator, {name}: {sca:.1f} simulated s per wall s ({cpu:.1f} per CPU s; "
              f"target >= 20): {'MET' if sca >= 20 else 'NOT MET'}; "
              f"load average {os.getloadavg()[0]:.2f}")
    n = int(0.5 * rate)
    plant = EmaBatch([RunSpec(params, seed=s) for s in range(104)])
    t0 = time.perf_counter()
    plant.advance(n, 10.0, 1500.0)
    wall = time.perf_counter() - t0
    print(f"104 actuators in one batch: {104 * n / rate / wall:.1f} actuator-s per wall s")
    groups = CONDITIONS[:1] if args.quick else CONDITIONS
    t0 = time.perf_counter()
    runs = 0
    duration = 0.0
    for k, cond in enumerate(groups):
        prof = bit_profile(rate, cond)
        specs = dictionary_group(params, k)
        run_batch(specs, prof)
        runs += len(specs)
        duration = prof.time_s[-1]
    wall = time.perf_counter() - t0
    total = wall * len(CONDITIONS) / len(groups)
    how = "extrapolated from one group" if args.quick else "measured"
    print(f"416-run fault dictionary ({len(CONDITIONS)} conditions x 104 runs x "
          f"{duration:.2f} s BIT profile): {total:.1f} s wall ({how}; target <= 300 s): "
          f"{'MET' if total <= 300 else 'NOT MET'}; load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
