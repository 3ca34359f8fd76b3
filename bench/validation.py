"""The reasoner on its validation set: the runs its design choices were made on.

The accuracy benchmark's held-out runs (bench/accuracy.py, seeds from 21,240,000) must not
steer the reasoner's design, or its figures would be tuned to them. Choices such as the
matched filter's shrinkage (``matched.SHRINKAGE``), the record rows pooled per healthy cell and
the rejected alternatives in docs/reasoner.md were measured here instead: 650 BIT runs with
their own seeds (from 5,000,000) and their own draws — 30 runs of each fault mode, 60 of each
SMPS switch Ron and 80 of the inverter phase-A Ron (the weak ones), magnitudes 20-100 % of each
range, short/open on a random switch, 300 healthy runs, dynamic pressures 100-2400 Pa. The
dictionary's runs (seeds from 0) and the calibration runs its thresholds come from are
disjoint from both sets.

Prints, per mode, how the runs were decided (mode names, ``other`` for an anomaly no
template explains, ``none`` for no anomaly), the misses with their magnitude and pressure,
and the healthy runs' alarms.

Run:  python3 bench/validation.py [--dictionary FILE]  (builds the shipped dictionary if
none is given; ~1-2 min on two cores).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mapr_daemon.ema.faults import SWITCHES, Fault, FaultSet, at_severity
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.diagnosis import classifier
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary, DictionarySpec
from mapr_daemon.reasoner.training.corpus import simulate_bit
from mapr_daemon.reasoner.training.dictionary_build import build, run_matrices

MODES = ("capacitance", "esr", "smps_ron_high", "smps_ron_low", "inverter_ron_a_high",
         "friction", "short", "open")
RUNS_PER_MODE = {"inverter_ron_a_high": 80, "smps_ron_low": 60, "smps_ron_high": 60}
"""Runs per mode (30 unless named): more where the design choices were about."""
HEALTHY_RUNS = 300
FIRST_SEED = 5_000_000
DRAW_SEED = 777


def validation_set() -> tuple[list[FaultSet], list[str], list[float], list[float], list[int]]:
    """Fault sets, true modes ('' = healthy), magnitudes, pressures and seeds of the set."""
    params = load_actuator(default_actuator_path())
    rng = np.random.default_rng(DRAW_SEED)
    faults: list[FaultSet] = []
    modes: list[str] = []
    sev: list[float] = []
    for kind in MODES:
        for _ in range(RUNS_PER_MODE.get(kind, 30)):
            if kind in ("short", "open"):
                switch = SWITCHES[int(rng.integers(len(SWITCHES)))]
                faults.append(FaultSet.of([Fault(kind, switch=switch)]))
                sev.append(1.0)
            else:
                s = float(rng.uniform(0.2, 1.0))
                faults.append(FaultSet.of([at_severity(params, kind, s)]))
                sev.append(s)
            modes.append(kind)
    faults += [FaultSet()] * HEALTHY_RUNS
    modes += [""] * HEALTHY_RUNS
    sev += [0.0] * HEALTHY_RUNS
    qs = [float(q) for q in rng.uniform(100.0, 2400.0, len(faults))]
    return faults, modes, sev, qs, [FIRST_SEED + i for i in range(len(faults))]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dictionary", type=Path, help="use a built dictionary instead of building")
    args = ap.parse_args()
    start = time.monotonic()
    params = load_actuator(default_actuator_path())
    if args.dictionary:
        d = Dictionary.load(args.dictionary)
    else:
        root = Path(__file__).resolve().parents[1]
        d = build(params, DictionarySpec.load(root / "configs/reasoner/dictionary.yaml"))
    faults, modes, sev, qs, seeds = validation_set()
    runs = simulate_bit(params, faults, qs, seeds)
    m = run_matrices(runs, d.window_starts, d.window_samples, d.signals)
    decided = Counter()
    misses = []
    for i, mode in enumerate(modes):
        dec = classifier.decide(d, m[i], qs[i])
        got = (dec.fault or "other") if dec.anomaly else "none"
        decided[(mode, got)] += 1
        if got != (mode or "none"):
            misses.append((mode or "healthy", round(sev[i], 2), got, round(qs[i])))
    print(f"validation set: {len(modes)} runs (seeds {seeds[0]}-{seeds[-1]}); load average "
          f"{os.getloadavg()[0]:.2f}")
    for mode in (*MODES, ""):
        row = {g: n for (t, g), n in sorted(decided.items()) if t == mode}
        right = row.get(mode or "none", 0)
        print(f"{mode or 'healthy':>20} {right:3d}/{sum(row.values()):3d} right   {row}")
    for true, magnitude, got, q in sorted(misses):
        print(f"   miss: true {true} at {magnitude:.2f} of its range decided {got} (q {q} Pa)")
    faulted = [i for i, t in enumerate(modes) if t]
    detected = sum(n for (t, g), n in decided.items() if t and g != "none")
    alarms = sum(n for (t, g), n in decided.items() if not t and g != "none")
    print(f"detected {detected}/{len(faulted)}; healthy alarms {alarms}/{HEALTHY_RUNS}; "
          f"total {time.monotonic() - start:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
