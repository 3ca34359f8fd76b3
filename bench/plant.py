"""Plant speed: simulated seconds per wall second for one actuator, and a 416-run dictionary.

Integration method: fixed 25 us steps with numpy vectorised *across runs* (every state is an
array with one entry per run; the SMPS 2x2 system is advanced exactly per step, the winding
resistance implicitly). Why not scipy's compiled integrators: the plant switches every Hall
sector and diode event, so an adaptive solver would restart at each event and still call a
Python right-hand side per evaluation; vectorising across runs shares the per-step Python
overhead among all runs of a batch instead. The flip side, printed below: one actuator alone
pays the whole per-step overhead.

Run: ``python3 bench/plant.py`` (``--quick`` times one dictionary group and extrapolates).
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
from mapr_daemon.testbed.profiles import bit_profile

KINDS = ("capacitance", "esr", "smps_ron_high", "smps_ron_low", "inverter_ron_a_high", "friction")
CONDITIONS = ("ground", "approach", "cruise", "dash")


def dictionary_group(p: ActuatorParams, cond_index: int) -> list[RunSpec]:
    """The 104 runs of one flight condition (as configs/profiles/dictionary-416.yaml)."""
    sets = [FaultSet(), FaultSet()]
    sets += [FaultSet.of([at_severity(p, k, s / 16)]) for k in KINDS for s in range(1, 17)]
    sets += [FaultSet.of([Fault("short", switch=w)]) for w in ("A_high", "B_high", "C_low")]
    sets += [FaultSet.of([Fault("open", switch=w)]) for w in ("A_high", "B_low", "C_high")]
    return [RunSpec(p, fs, seed=1000 * cond_index + i) for i, fs in enumerate(sets)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    params = load_actuator(default_actuator_path())
    rate = params.sensors.sample_rate_hz
    print(f"machine: {os.cpu_count()} cores; step {params.sensors.step_s * 1e6:g} us, "
          f"sensor rate {rate:g} Hz")
    plant = EmaBatch([RunSpec(params, seed=1)])
    n = int(0.5 * rate)
    t0 = time.perf_counter()
    plant.advance(n, 10.0, 1500.0)
    wall = time.perf_counter() - t0
    print(f"one actuator alone: {n / rate / wall:.3f} simulated s per wall s "
          f"(target >= 20): {'MET' if n / rate / wall >= 20 else 'NOT MET'}")
    plant = EmaBatch([RunSpec(params, seed=s) for s in range(104)])
    t0 = time.perf_counter()
    plant.advance(n, 10.0, 1500.0)
    wall = time.perf_counter() - t0
    print(f"104 actuators in one batch: {104 * n / rate / wall:.2f} actuator-s per wall s "
          f"({n / rate / wall:.3f} s of batch time per wall s)")
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
          f"{'MET' if total <= 300 else 'NOT MET'}")


if __name__ == "__main__":
    main()
