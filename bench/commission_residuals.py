"""Does commissioning close the fit? Per-signal residuals before and after, in noise units.

Units are drawn off each actuator file by the mismatch harness (``mapr_daemon.testbed.
mismatch``: part-to-part parameters and a model form the data sheet does not carry). Each flies
``--bits`` healthy BITs at conditions over the envelope (a quarter on the ground) and is
identified from them as ``mapr commission`` does it (:func:`~mapr_daemon.reasoner.commissioning.
identify.identify`, the shipped tolerances). Printed per fit signal: the RMS of model minus
record with the data sheet's parameters (before) and the identified ones (after), in units of
the noise of what is compared (the signal's per-sample sensor noise over the square root of
the fit's decimation): 1 is a fit down to the noise. Median and worst over the units, the
identification's convergence, and seeds, CPU, wall and load.

Run:  python3 bench/commission_residuals.py [--units 3] [--bits 10] [--seed N]
      [--actuator FILE ...]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from seeds import master

from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.params import load_actuator
from mapr_daemon.reasoner.commissioning.bits import FIT_SIGNALS, from_runs, signal_noise
from mapr_daemon.reasoner.commissioning.identify import FitOptions, identify
from mapr_daemon.reasoner.training.corpus import simulate_bit
from mapr_daemon.testbed.mismatch import fleet

ROOT = Path(__file__).resolve().parents[1]
ACTUATORS = (ROOT / "configs/actuators/aileron-uav.yaml",
             ROOT / "configs/actuators/elevator-uav.yaml")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--actuator", type=Path, action="append")
    ap.add_argument("--units", type=int, default=3)
    ap.add_argument("--bits", type=int, default=10)
    ap.add_argument("--seed", type=int, help="master seed (default: drawn afresh, printed)")
    args = ap.parse_args()
    seed = master(args.seed, f"python3 bench/commission_residuals.py --units "
                  f"{args.units} --bits {args.bits}")
    start, cpu0 = time.monotonic(), time.process_time()
    rng = np.random.default_rng(seed)
    decimate = FitOptions().decimate
    for path in args.actuator or ACTUATORS:
        sheet = load_actuator(path)
        env = sheet.envelope
        noise = {k: v / math.sqrt(decimate) for k, v in signal_noise(sheet).items()}
        before: dict[str, list[float]] = {k: [] for k in FIT_SIGNALS}
        after: dict[str, list[float]] = {k: [] for k in FIT_SIGNALS}
        notes = []
        for unit in fleet(sheet, args.units, int(rng.integers(2**31))):
            specs = [unit.spec(FaultSet(), seed=int(rng.integers(10**9, 2**62)),
                               ambient_c=float(rng.uniform(env.ambient_min_c,
                                                           env.ambient_max_c)),
                               bus_v=float(rng.uniform(sheet.bus.min_v, sheet.bus.max_v)))
                     for _ in range(args.bits)]
            q = [0.0 if rng.random() < 0.25 else float(rng.uniform(0.0,
                                                                   env.max_dynamic_pressure_pa))
                 for _ in range(args.bits)]
            runs = simulate_bit(sheet, [], q, [], specs=specs)
            ident = identify(sheet, from_runs(runs, "bench"))
            for k in FIT_SIGNALS:
                before[k].append(ident.residual_before[k] / noise[k])
                after[k].append(ident.residual_after[k] / noise[k])
            notes.append(f"{len(ident.bits)} BITs used, {ident.iterations} iterations, "
                         f"{'converged' if ident.converged else 'NOT converged'}")
        print(f"\n{sheet.name}: {args.units} mismatched units, {args.bits} healthy BITs each; "
              + "; ".join(notes))
        print(f"{'signal':>24} {'before: median':>15} {'worst':>8} {'after: median':>14} "
              f"{'worst':>8}")
        for k in FIT_SIGNALS:
            print(f"{k:>24} {np.median(before[k]):15.1f} {max(before[k]):8.1f} "
                  f"{np.median(after[k]):14.1f} {max(after[k]):8.1f}")
    print(f"\n(noise units: the signal's sensor noise over sqrt({decimate}), the fit's "
          f"decimation)\ntotal wall {time.monotonic() - start:.1f} s, CPU "
          f"{time.process_time() - cpu0:.1f} s; load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
