"""Do fault readings transfer to units that are not the model's twin? Mode and severity read
against each unit's own commissioned healthy behaviour.

Units are drawn off each actuator file by the mismatch harness (``mapr_daemon.testbed.
mismatch``). Each flies ``--bits`` healthy BITs to commission from (identification as
``mapr commission`` does it, then the learned discrepancy), ``--healthy`` more healthy BITs,
and ``--per-mode`` faulted BITs per mode (parametric modes at 25-100 % of the Table 1 range,
short and open on a random switch), all at conditions drawn over the envelope (a quarter on
the ground). Every faulted and held-out healthy BIT is read by
:func:`~mapr_daemon.reasoner.commissioning.severity.read` against

* the identified model plus the discrepancy (the unit's commissioned healthy behaviour), and
* the identified model alone (what the fit gives without the discrepancy),

and, with ``--dictionary``, decided by the dictionary classifier (the data sheet's dictionary
calibrated to the unit on the same commissioning BITs, as ``bench/units.py`` does it).

Printed per mode: BITs, mode named right, part named right, and the severity error (|read -
true|, fraction of the range) where the mode was named right, mean and worst. "Separable":
faulted BITs whose cost drop (healthy hypothesis minus best, in healthy spreads) exceeds the
largest drop of any held-out healthy BIT of that actuator's fleet — how well faults stand
out of the unit's healthy scatter, not a calibrated detector.

Run:  python3 bench/severity_transfer.py [--units 3] [--bits 12] [--healthy 3]
      [--per-mode 2] [--seed N] [--actuator FILE ...] [--dictionary FILE ...]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from commission_residuals import unit_bits
from seeds import master

from mapr_daemon.ema.faults import PARAMETRIC, SWITCHES, Fault, FaultSet, at_severity
from mapr_daemon.ema.params import load_actuator
from mapr_daemon.reasoner.commissioning import calibrate
from mapr_daemon.reasoner.commissioning.discrepancy import learn_unit
from mapr_daemon.reasoner.commissioning.identify import FitOptions, identify
from mapr_daemon.reasoner.commissioning.severity import HEALTHY, Reading, read
from mapr_daemon.reasoner.diagnosis import classifier, parts
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.testbed.mismatch import fleet

ROOT = Path(__file__).resolve().parents[1]
ACTUATORS = (ROOT / "configs/actuators/aileron-uav.yaml",
             ROOT / "configs/actuators/elevator-uav.yaml")
MODES = (*PARAMETRIC, "short", "open")
Row = tuple[str, float, str | None, float | None, float]
"""(true mode, true severity, named mode or None, read severity, cost drop)."""


def as_row(mode: str, sev: float, r: Reading) -> Row:
    named = None if r.mode == HEALTHY else r.mode
    return (mode, sev, named, r.severity, r.healthy_cost - r.cost)


def report(name: str, rows: list[Row], healthy: list[float] | None) -> None:
    print(f"\n== {name}")
    limit = max(healthy) if healthy else None
    if healthy:
        print(f"held-out healthy BITs: {len(healthy)}, cost drop median "
              f"{np.median(healthy):.2f}, largest {limit:.2f}")
    print(f"{'mode':>20} {'BITs':>5} {'mode right':>11} {'part right':>11} "
          f"{'sev err mean/worst':>19}" + (f" {'separable':>10}" if limit is not None else ""))
    errs_all: list[float] = []
    tot = np.zeros(4)
    for mode in MODES:
        rs = [r for r in rows if r[0] == mode]
        if not rs:
            continue
        right = [r for r in rs if r[2] == mode]
        part = sum(parts.same_part(mode, r[2]) for r in rs)
        errs = [abs(r[3] - r[1]) for r in right if mode in PARAMETRIC and r[3] is not None]
        errs_all += errs
        sep = sum(r[4] > limit for r in rs) if limit is not None else 0
        tot += (len(rs), len(right), part, sep)
        sev = f"{np.mean(errs):.3f}/{max(errs):.3f}" if errs else "-"
        print(f"{mode:>20} {len(rs):5d} {len(right):5d} ({100 * len(right) / len(rs):3.0f}%) "
              f"{part:5d} ({100 * part / len(rs):3.0f}%) {sev:>19}"
              + (f" {sep:4d} ({100 * sep / len(rs):3.0f}%)" if limit is not None else ""))
    n = max(tot[0], 1)
    sev = f"{np.mean(errs_all):.3f}/{max(errs_all):.3f}" if errs_all else "-"
    print(f"{'all modes':>20} {int(tot[0]):5d} {int(tot[1]):5d} ({100 * tot[1] / n:3.0f}%) "
          f"{int(tot[2]):5d} ({100 * tot[2] / n:3.0f}%) {sev:>19}"
          + (f" {int(tot[3]):4d} ({100 * tot[3] / n:3.0f}%)" if limit is not None else ""))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--actuator", type=Path, action="append")
    ap.add_argument("--dictionary", type=Path, action="append",
                    help="the data sheet's dictionary, one per --actuator, same order")
    ap.add_argument("--units", type=int, default=3)
    ap.add_argument("--bits", type=int, default=12)
    ap.add_argument("--healthy", type=int, default=3)
    ap.add_argument("--per-mode", type=int, default=2)
    ap.add_argument("--seed", type=int, help="master seed (default: drawn afresh, printed)")
    args = ap.parse_args()
    files = "".join(f" --actuator {a}" for a in args.actuator or []) + "".join(
        f" --dictionary {d}" for d in args.dictionary or [])
    seed = master(args.seed, f"python3 bench/severity_transfer.py --units {args.units} "
                  f"--bits {args.bits} --healthy {args.healthy} --per-mode {args.per_mode}"
                  + files)
    start, cpu0 = time.monotonic(), time.process_time()
    rng = np.random.default_rng(seed)
    dec = FitOptions().decimate
    actuators = args.actuator or list(ACTUATORS)
    dictionaries = args.dictionary or [None] * len(actuators)
    for path, dict_path in zip(actuators, dictionaries, strict=True):
        sheet = load_actuator(path)
        d = Dictionary.load(dict_path) if dict_path else None
        if d is not None and d.sample_rate_hz != sheet.sensors.sample_rate_hz:
            print(f"{dict_path}: built at {d.sample_rate_hz:g} Hz, {path} samples at "
                  f"{sheet.sensors.sample_rate_hz:g} Hz", file=sys.stderr)
            return 2
        with_disc: list[Row] = []
        without: list[Row] = []
        by_dict: list[Row] = []
        healthy_drop: list[float] = []
        healthy_drop0: list[float] = []
        notes = []
        for unit in fleet(sheet, args.units, int(rng.integers(2**31))):
            truth: list[tuple[str, float]] = []
            faults: list[FaultSet] = []
            for mode in MODES:
                for _ in range(args.per_mode):
                    if mode in PARAMETRIC:
                        s = float(rng.uniform(0.25, 1.0))
                        faults.append(FaultSet.of([at_severity(sheet, mode, s)]))
                    else:
                        s = 1.0
                        sw = SWITCHES[int(rng.integers(len(SWITCHES)))]
                        faults.append(FaultSet.of([Fault(mode, switch=sw)]))
                    truth.append((mode, s))
            comm = unit_bits(sheet, unit, [FaultSet()] * args.bits, rng, "commission")
            held = unit_bits(sheet, unit, [FaultSet()] * args.healthy, rng, "healthy")
            faulted = unit_bits(sheet, unit, faults, rng, "faulted")
            ident = identify(sheet, comm)
            used = [b for b in comm if b.index in {u.index for u in ident.bits}]
            disc = learn_unit(ident.params, used, dec)
            t0 = time.monotonic()
            for b in held:
                healthy_drop.append(as_row("", 0.0, read(ident.params, sheet, disc, b,
                                                         dec))[4])
                healthy_drop0.append(as_row("", 0.0, read(ident.params, sheet, None, b,
                                                          dec))[4])
            for (mode, s), b in zip(truth, faulted, strict=True):
                with_disc.append(as_row(mode, s, read(ident.params, sheet, disc, b, dec)))
                without.append(as_row(mode, s, read(ident.params, sheet, None, b, dec)))
            if d is not None:
                m = np.stack([d.record_matrix(b.channels, b.command_deg) for b in used])
                unit_d, _ = calibrate.calibrate_unit(
                    d, m, np.array([b.dynamic_pressure_pa for b in used]))
                for (mode, s), b in zip(truth, faulted, strict=True):
                    dec_ = classifier.decide(unit_d, d.record_matrix(b.channels, b.command_deg),
                                             b.dynamic_pressure_pa)
                    named = dec_.fault if dec_.anomaly else None
                    by_dict.append((mode, s, named, dec_.severity, 0.0))
            notes.append(f"unit {unit.seed}: {len(ident.bits)} BITs used, {ident.iterations} "
                         f"iterations, {'converged' if ident.converged else 'NOT CONVERGED'}, "
                         f"{len(held) + 2 * len(faulted)} readings in "
                         f"{time.monotonic() - t0:.0f} s")
        print(f"\n{sheet.name}: {args.units} mismatched units, {args.bits} commissioning BITs, "
              f"{args.healthy} held-out healthy and {len(MODES) * args.per_mode} faulted BITs "
              "each")
        for n in notes:
            print("  " + n)
        report("read against identified model + discrepancy", with_disc, healthy_drop)
        report("read against the identified model alone", without, healthy_drop0)
        if by_dict:
            report("the dictionary classifier (data sheet's, calibrated to the unit; mode "
                   "right = anomaly with that fault named)", by_dict, None)
    print(f"\n(severity error: fraction of the Table 1 range, where the mode was named right)"
          f"\ntotal wall {time.monotonic() - start:.1f} s, CPU {time.process_time() - cpu0:.1f}"
          f" s; load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
