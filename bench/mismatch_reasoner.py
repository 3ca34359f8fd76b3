"""How the reasoner judges healthy mismatched units: false alarms against their data-sheet twins.

A fleet of healthy units (``mapr_daemon.testbed.mismatch.fleet``) and as many healthy data-sheet
twins fly the BIT at the same conditions, drawn uniformly over the actuator file's envelope
(dynamic pressure, ambient temperature, aircraft bus), with the same noise seeds; every record
goes through ``classifier.decide`` against a dictionary built from the data sheet. Printed: the
anomaly count of each group, the score over the threshold (mean and worst record), the same for
the units' parameters alone (default form) and their form alone (data-sheet parameters), and the
units' anomaly count per model-form option. The fleet and condition seeds are printed.

Run (the dictionary from the same actuator file)::

    mapr dictionary build --actuator configs/actuators/elevator-uav.yaml -o elevator.npz
    python3 bench/mismatch_reasoner.py --actuator configs/actuators/elevator-uav.yaml \\
        --dictionary elevator.npz [--units 40] [--seed 2024]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from seeds import fresh as fresh_seed

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training.corpus import Runs, simulate_bit
from mapr_daemon.testbed.mismatch import fleet


def judge(reasoner: Reasoner, runs: Runs) -> tuple[np.ndarray, np.ndarray]:
    """Per record: anomaly flag and score over threshold."""
    flags, ratios = [], []
    for i in range(runs.n):
        m = reasoner.matrix({k: v[i] for k, v in runs.channels.items()}, runs.command_deg)
        dec = reasoner.decide(m, float(runs.dynamic_pressure_pa[i]))
        flags.append(dec.anomaly)
        ratios.append(dec.score / dec.threshold if dec.threshold else np.nan)
    return np.array(flags), np.array(ratios)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--actuator", type=Path, default=default_actuator_path())
    ap.add_argument("--dictionary", type=Path, required=True)
    ap.add_argument("--units", type=int, default=40)
    ap.add_argument("--seed", type=int, help="default: drawn afresh (printed)")
    args = ap.parse_args()
    args.seed = fresh_seed(args.seed)
    sheet = load_actuator(args.actuator)
    reasoner = Reasoner(Dictionary.load(args.dictionary), sheet)
    env = sheet.envelope
    rng = np.random.default_rng(args.seed + 1)
    n = args.units
    q = rng.uniform(0.0, env.max_dynamic_pressure_pa, n)
    amb = rng.uniform(env.ambient_min_c, env.ambient_max_c, n)
    bus = rng.uniform(sheet.bus.min_v, sheet.bus.max_v, n)
    seeds = [10_000 + k for k in range(n)]
    print(f"{sheet.name}: {n} healthy units (fleet seed {args.seed}) and {n} data-sheet twins, "
          f"conditions drawn with seed {args.seed + 1}, noise seeds {seeds[0]}..{seeds[-1]}")
    t0 = time.perf_counter()
    units = fleet(sheet, n, seed=args.seed)
    groups = {
        "twins": [RunSpec(sheet, seed=s, ambient_c=float(a), bus_v=float(b))
                  for s, a, b in zip(seeds, amb, bus, strict=True)],
        "units": [u.spec(seed=s, ambient_c=float(a), bus_v=float(b))
                  for u, s, a, b in zip(units, seeds, amb, bus, strict=True)],
        "units' parameters, default form": [
            RunSpec(u.params, seed=s, ambient_c=float(a), bus_v=float(b))
            for u, s, a, b in zip(units, seeds, amb, bus, strict=True)],
        "data sheet's parameters, units' form": [
            RunSpec(sheet, seed=s, ambient_c=float(a), bus_v=float(b), form=u.form)
            for u, s, a, b in zip(units, seeds, amb, bus, strict=True)],
    }
    flags: dict[str, np.ndarray] = {}
    for name, specs in groups.items():
        runs = simulate_bit(sheet, [], list(q), [], specs=specs)
        flags[name], ratio = judge(reasoner, runs)
        print(f"  {name}: {int(flags[name].sum())}/{n} flagged anomalous; score/threshold "
              f"mean {np.nanmean(ratio):.2f}, median {np.nanmedian(ratio):.2f}, worst "
              f"{np.nanmax(ratio):.2f}")
    forms = [u.form for u in units]
    options = {
        "stiction": [f.breakaway_ratio > 0 for f in forms],
        "voltage mode": [f.voltage_mode for f in forms],
        "discrete loops": [f.current_loop_hz > 0 for f in forms],
        "|Hall offset| > 3 deg": [abs(f.hall_offset_deg) > 3.0 for f in forms],
    }
    for name, has in options.items():
        sel = np.array(has)
        print(f"  units with {name}: {int(flags['units'][sel].sum())}/{int(sel.sum())} flagged;"
              f" without: {int(flags['units'][~sel].sum())}/{int((~sel).sum())}")
    print(f"wall time {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
