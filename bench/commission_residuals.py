"""Does commissioning close the fit? Per-signal residuals on held-out healthy BITs, in noise units.

Units are drawn off each actuator file by the mismatch harness (``mapr_daemon.testbed.
mismatch``: part-to-part parameters and a model form the data sheet does not carry). Each flies
``--bits`` healthy BITs to commission from and ``--held-out`` more it is judged on, all at
conditions drawn over the envelope (a quarter on the ground). It is identified from the first
set as ``mapr commission`` does it (:func:`~mapr_daemon.reasoner.commissioning.identify.
identify`, the shipped tolerances), and the learned discrepancy is fitted on the BITs the
identification used (:func:`~mapr_daemon.reasoner.commissioning.discrepancy.learn_unit`).

Printed per fit signal, on the HELD-OUT BITs (none of them seen by the identification or the
discrepancy), the RMS of record minus prediction, in units of the noise of what is compared
(the signal's per-sample sensor noise over the square root of the fit's decimation; 1 is a fit
down to the noise): the data sheet's model, the identified model, and the identified model
plus the discrepancy; median and worst over the units. Also per unit the identification's
iterations and convergence, the discrepancy's ranks, and seeds, CPU, wall and load.

``--twin`` flies the data sheet's own twin instead (its parameters, the plant's own form):
what is left then is the floor no condition-driven correction can reach — the flight's own
friction scatter, the aircraft bus's drift and ripple, the sensor noise.

Run:  python3 bench/commission_residuals.py [--units 4] [--bits 12] [--held-out 6]
      [--seed N] [--actuator FILE ...] [--twin]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from seeds import master

from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import ActuatorParams, load_actuator
from mapr_daemon.reasoner.commissioning.bits import FIT_SIGNALS, BitRecord, from_runs
from mapr_daemon.reasoner.commissioning.discrepancy import correction_for, learn_unit
from mapr_daemon.reasoner.commissioning.flight import Flight, fly, noise_scale, recorded
from mapr_daemon.reasoner.commissioning.identify import FitOptions, identify
from mapr_daemon.reasoner.training.corpus import simulate_bit
from mapr_daemon.testbed.mismatch import Unit, fleet

ROOT = Path(__file__).resolve().parents[1]
ACTUATORS = (ROOT / "configs/actuators/aileron-uav.yaml",
             ROOT / "configs/actuators/elevator-uav.yaml")
GROUND_SHARE = 0.25


def unit_bits(sheet: ActuatorParams, unit: Unit, faults: list[FaultSet],
              rng: np.random.Generator, source: str) -> list[BitRecord]:
    """The unit flown through one BIT per fault set, each at a condition drawn over the
    envelope (a quarter on the ground)."""
    env = sheet.envelope
    specs = [unit.spec(f, seed=int(rng.integers(10**9, 2**62)),
                       ambient_c=float(rng.uniform(env.ambient_min_c, env.ambient_max_c)),
                       bus_v=float(rng.uniform(sheet.bus.min_v, sheet.bus.max_v)))
             for f in faults]
    q = [0.0 if rng.random() < GROUND_SHARE else float(
        rng.uniform(0.0, env.max_dynamic_pressure_pa)) for _ in faults]
    return from_runs(simulate_bit(sheet, [], q, [], specs=specs), source)


def rms_per_signal(residual: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """(K,) RMS over BITs and time of ``residual (n, K, T)`` in noise units."""
    out: np.ndarray = np.sqrt(np.mean((residual / scale[None, :, None]) ** 2, axis=(0, 2)))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--actuator", type=Path, action="append")
    ap.add_argument("--units", type=int, default=4)
    ap.add_argument("--bits", type=int, default=12)
    ap.add_argument("--held-out", type=int, default=6)
    ap.add_argument("--seed", type=int, help="master seed (default: drawn afresh, printed)")
    ap.add_argument("--twin", action="store_true", help="the data sheet's twin, not mismatched "
                    "units: the floor")
    args = ap.parse_args()
    seed = master(args.seed, f"python3 bench/commission_residuals.py --units {args.units} "
                  f"--bits {args.bits} --held-out {args.held_out}"
                  + (" --twin" if args.twin else ""))
    start, cpu0 = time.monotonic(), time.process_time()
    rng = np.random.default_rng(seed)
    dec = FitOptions().decimate
    columns = ("data sheet", "identified", "+ discrepancy")
    for path in args.actuator or ACTUATORS:
        sheet = load_actuator(path)
        scale = noise_scale(sheet, dec)
        table: dict[str, list[np.ndarray]] = {c: [] for c in columns}
        notes = []
        units = fleet(sheet, args.units, int(rng.integers(2**31)))
        if args.twin:
            units = [Unit(u.seed, sheet, sheet, ModelForm(), {}) for u in units]
        for unit in units:
            comm = unit_bits(sheet, unit, [FaultSet()] * args.bits, rng, "commission")
            held = unit_bits(sheet, unit, [FaultSet()] * args.held_out, rng, "held-out")
            ident = identify(sheet, comm)
            used = {b.index for b in ident.bits}
            disc = learn_unit(ident.params, [b for b in comm if b.index in used], dec)
            data = recorded(held, dec)
            flights = [Flight(b) for b in held]
            table["data sheet"].append(rms_per_signal(data - fly(sheet, flights, dec), scale))
            ident_model = fly(ident.params, flights, dec)
            table["identified"].append(rms_per_signal(data - ident_model, scale))
            corr = correction_for(disc, ident.params, held)
            table["+ discrepancy"].append(rms_per_signal(data - ident_model - corr, scale))
            ranks = "".join(str(f.rank) for f in disc.fits)
            notes.append(f"unit {unit.seed}: {len(ident.bits)} BITs used, {ident.iterations} "
                         f"iterations, {'converged' if ident.converged else 'NOT CONVERGED'}, "
                         f"discrepancy ranks {ranks}")
        print(f"\n{sheet.name}: {args.units} {'twins' if args.twin else 'mismatched units'}, "
              f"{args.bits} commissioning and "
              f"{args.held_out} held-out healthy BITs each")
        for n in notes:
            print("  " + n)
        print(f"{'held-out residual':>24}" + "".join(f"{c + ': median':>26} {'worst':>7}"
                                                       for c in columns))
        for j, k in enumerate(FIT_SIGNALS):
            print(f"{k:>24}" + "".join(
                f"{np.median([v[j] for v in table[c]]):26.1f} {max(v[j] for v in table[c]):7.1f}"
                for c in columns))
    print(f"\n(noise units: the signal's sensor noise over sqrt({dec}), the fit's decimation;"
          f" ranks per signal in the order above)\ntotal wall {time.monotonic() - start:.1f} s, "
          f"CPU {time.process_time() - cpu0:.1f} s; load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
