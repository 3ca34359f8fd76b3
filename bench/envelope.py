"""The reasoner over the whole operating envelope, on seeds drawn afresh at every run.

What a maintenance engineer meets and the dictionary was not designed on: healthy BITs
anywhere in the actuator's envelope — on the ground (no air load), from 0 Pa to the actuator
file's maximum dynamic pressure, ambient -40..+70 C (the file's ``envelope``), aircraft bus
22..29 V (MIL-STD-704 normal) — and faults of every Table 1 mode at 5-100 % of its range at the
same conditions.

Seeds: one master seed, drawn from the operating system unless ``--seed`` is given, is printed
first; every condition, magnitude and per-run noise seed is derived from it (per-run seeds are
drawn in 10^9..2^62, far from the dictionary's seeds (from 0), the validation set's (from
5,000,000), the estimators' (from 3,000,000 and 7,000,000) and the accuracy bench's). Rerun a
printed figure with ``--seed``.

Printed: false alarms among healthy BITs, overall and per stratum (ground, below 0 C, above
50 C, low bus), with the inconclusive ones (aircraft bus below the SMPS's headroom: no
decision, not an alarm) counted apart; per mode, detection and isolation (to the mode and to
the replaceable part) at >= 25 % of range, the severity error, and the 90 %-detection floor:
the magnitude at which a logistic fit of detected-or-not on magnitude reaches 90 % ("> 100%"
where it does not within the range), with the observed detection rate per magnitude band
beside it.

Run:  python3 bench/envelope.py [--dictionary FILE] [--seed N] [--healthy 1000]
      [--per-mode 100] [--actuator FILE]
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mapr_daemon.ema.faults import SWITCHES, Fault, FaultSet, at_severity
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.reasoner.diagnosis import classifier, parts
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary, DictionarySpec
from mapr_daemon.reasoner.training.corpus import simulate_bit
from mapr_daemon.reasoner.training.dictionary_build import build, run_matrices

MODES = ("capacitance", "esr", "smps_ron_high", "smps_ron_low", "inverter_ron_a_high",
         "friction", "short", "open")
GROUND_SHARE = 0.25
"""Share of the BITs flown on the ground (0 Pa): the most common BIT is the pre-flight one."""
BANDS = (0.05, 0.10, 0.15, 0.25, 0.50, 0.75, 1.0001)


def draw_conditions(rng: np.random.Generator, params: ActuatorParams,
                    n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dynamic pressure, ambient temperature and bus mean per run, over the whole envelope."""
    env = params.envelope
    q = rng.uniform(0.0, env.max_dynamic_pressure_pa, n)
    q[rng.random(n) < GROUND_SHARE] = 0.0
    t = rng.uniform(env.ambient_min_c, env.ambient_max_c, n)
    v = rng.uniform(params.bus.min_v, params.bus.max_v, n)
    return q, t, v


def floor_90(mag: np.ndarray, hit: np.ndarray) -> float:
    """Magnitude at which a logistic fit of detection on magnitude reaches 90 %
    (nan when the fit cannot place it: all detected gives the smallest magnitude tried)."""
    if hit.all():
        return float(mag.min())
    if not hit.any():
        return math.nan

    def nll(w: np.ndarray) -> float:
        z = w[0] + w[1] * mag
        return float(np.sum(np.logaddexp(0.0, z) - hit * z))

    w = minimize(nll, np.array([0.0, 10.0]), method="Nelder-Mead").x
    if w[1] <= 0:
        return math.nan
    return float((math.log(9.0) - w[0]) / w[1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dictionary", type=Path, help="a built dictionary (default: build one)")
    ap.add_argument("--actuator", type=Path, help="actuator YAML (default: aileron-uav)")
    ap.add_argument("--seed", type=int, help="master seed (default: drawn afresh, printed)")
    ap.add_argument("--healthy", type=int, default=1000, help="healthy BITs")
    ap.add_argument("--per-mode", type=int, default=100, help="faulted BITs per mode")
    args = ap.parse_args()
    seed = int(args.seed if args.seed is not None
               else np.random.SeedSequence().entropy % 2**63)  # type: ignore[operator]
    given = "".join(f" --{k.replace('_', '-')} {v}" for k, v in (
        ("actuator", args.actuator), ("dictionary", args.dictionary),
        ("healthy", args.healthy), ("per_mode", args.per_mode)) if v is not None)
    print(f"master seed {seed}  (rerun: python3 bench/envelope.py{given} --seed {seed})")
    print(f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())} (2 cores, shared)")
    start, cpu0 = time.monotonic(), time.process_time()
    params = load_actuator(args.actuator or default_actuator_path())
    root = Path(__file__).resolve().parents[1]
    if args.dictionary:
        d = Dictionary.load(args.dictionary)
    else:
        d = build(params, DictionarySpec.load(root / "configs/reasoner/dictionary.yaml"))
    rng = np.random.default_rng(seed)
    truth: list[tuple[str, float]] = []
    faults: list[FaultSet] = []
    for kind in MODES:
        for _ in range(args.per_mode):
            if kind in ("short", "open"):
                sw = SWITCHES[int(rng.integers(len(SWITCHES)))]
                faults.append(FaultSet.of([Fault(kind, switch=sw)]))
                truth.append((kind, 1.0))
            else:
                s = float(rng.uniform(0.05, 1.0))
                faults.append(FaultSet.of([at_severity(params, kind, s)]))
                truth.append((kind, s))
    faults += [FaultSet()] * args.healthy
    truth += [("", 0.0)] * args.healthy
    q, amb, bus = draw_conditions(rng, params, len(faults))
    seeds = [int(s) for s in rng.integers(10**9, 2**62, len(faults))]
    t0 = time.monotonic()
    sim = simulate_bit(params, faults, list(q), seeds, ambient_c=list(amb), bus_v=list(bus))
    m = run_matrices(sim, d.window_starts, d.window_samples, d.signals)
    t_sim = time.monotonic() - t0
    decisions = [classifier.decide(d, m[i], float(q[i])) for i in range(len(faults))]
    print(f"{len(faults)} BITs ({args.healthy} healthy, {args.per_mode} per mode) simulated and "
          f"decided in {time.monotonic() - t0:.1f} s (simulation {t_sim:.1f} s)")
    report_healthy(truth, decisions, q, amb, bus)
    report_faults(truth, decisions, bus,
                  params.smps.output_voltage_v / params.smps.max_duty)
    print(f"\ntotal wall {time.monotonic() - start:.1f} s, CPU {time.process_time() - cpu0:.1f} s;"
          f" load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


def report_healthy(truth: list[tuple[str, float]], decisions: list[classifier.Decision],
                   q: np.ndarray, amb: np.ndarray, bus: np.ndarray) -> None:
    """False alarms per stratum, inconclusive BITs apart, and what the alarms named."""
    idx = [i for i, (k, _) in enumerate(truth) if not k]
    alarm = np.array([decisions[i].anomaly for i in idx])
    inconc = np.array(["inconclusive" in decisions[i].evidence for i in idx])
    qh, th, vh = q[idx], amb[idx], bus[idx]
    print("\n== healthy BITs over the envelope")
    print(f"{'stratum':>28} {'BITs':>6} {'alarms':>7} {'inconclusive':>13}")
    strata = (("all", np.ones(len(idx), bool)), ("on the ground (0 Pa)", qh == 0.0),
              ("in the air", qh > 0.0), ("below 0 C", th < 0.0), ("below -20 C", th < -20.0),
              ("above 50 C", th > 50.0), ("bus below 25.8 V", vh < 25.8),
              ("ground and below 0 C", (qh == 0.0) & (th < 0.0)))
    for name, mask in strata:
        print(f"{name:>28} {int(mask.sum()):6d} {int(alarm[mask].sum()):7d} "
              f"{int(inconc[mask].sum()):13d}")
    named = Counter(decisions[i].fault or "unexplained" for i, a in zip(idx, alarm, strict=True)
                    if a)
    if named:
        print("alarms named: " + ", ".join(f"{k} {v}" for k, v in named.most_common()))
    worst = [(decisions[i].score / decisions[i].threshold, i) for i in idx]
    r, i = max(worst)
    print(f"largest healthy score / threshold: {r:.2f} (q {q[i]:.0f} Pa, {amb[i]:.1f} C, "
          f"bus {bus[i]:.2f} V)")


def report_faults(truth: list[tuple[str, float]], decisions: list[classifier.Decision],
                  bus: np.ndarray, knee_v: float) -> None:
    """Per mode: detection, isolation to mode and to part at >= 25 %, severity error, floor;
    then detection at >= 25 % split at the SMPS's dropout knee (what the bus data can show of
    the SMPS switches depends on the off-time the low side conducts in)."""
    print("\n== faulted BITs (conclusive ones; magnitudes 5-100 % of range)")
    print(f"{'mode':>20} {'>=25%':>6} {'detected':>15} {'isolated':>15} {'to part':>15} "
          f"{'sev err %':>9} {'90% floor':>9}  detection per band "
          + " ".join(f"{BANDS[k]:.2f}-" for k in range(len(BANDS) - 1)))
    tot = Counter[str]()
    for mode in MODES:
        rows = [i for i, (k, _) in enumerate(truth) if k == mode
                and "inconclusive" not in decisions[i].evidence]
        mag = np.array([truth[i][1] for i in rows])
        hit = np.array([decisions[i].anomaly for i in rows])
        big = [i for i in rows if truth[i][1] >= 0.25]
        det = sum(decisions[i].anomaly for i in big)
        iso = sum(decisions[i].anomaly and decisions[i].fault == mode for i in big)
        part = sum(decisions[i].anomaly and parts.same_part(mode, decisions[i].fault)
                   for i in big)
        err = [100 * abs((decisions[i].severity or 0.0) - truth[i][1]) for i in big
               if decisions[i].fault == mode and decisions[i].severity is not None]
        floor = floor_90(mag, hit) if mode not in ("short", "open") else math.nan
        bands = []
        for lo, hi in itertools.pairwise(BANDS):
            sel = (mag >= lo) & (mag < hi)
            bands.append(f"{hit[sel].mean():5.2f}" if sel.any() else "    -")
        n = max(len(big), 1)
        e = f"{np.mean(err):9.1f}" if err else f"{'-':>9}"
        f = (f"{'> 100%':>9}" if math.isfinite(floor) and floor > 1.0
             else f"{100 * floor:8.1f}%" if math.isfinite(floor) else f"{'-':>9}")
        print(f"{mode:>20} {len(big):6d} {det:5d} ({100 * det / n:5.1f}%) {iso:5d} "
              f"({100 * iso / n:5.1f}%) {part:5d} ({100 * part / n:5.1f}%) {e} {f}  "
              + " ".join(bands))
        tot.update(runs=len(big), det=det, iso=iso, part=part)
    n = max(tot["runs"], 1)
    print(f"{'all modes':>20} {tot['runs']:6d} {tot['det']:5d} ({100 * tot['det'] / n:5.1f}%) "
          f"{tot['iso']:5d} ({100 * tot['iso'] / n:5.1f}%) {tot['part']:5d} "
          f"({100 * tot['part'] / n:5.1f}%)")
    print()
    print("detection at >= 25 % of range, bus mean below / above the SMPS's duty limit "
          f"(Vout/max_duty = {knee_v:.2f} V: below it the low side conducts 5 % of the period)")
    for mode in MODES:
        big = [i for i, (k, s) in enumerate(truth) if k == mode and s >= 0.25]
        cols = []
        for sel in ([i for i in big if bus[i] < knee_v], [i for i in big if bus[i] >= knee_v]):
            hit = sum(decisions[i].anomaly for i in sel)
            cols.append(f"{hit:4d}/{len(sel):<4d} ({100 * hit / max(len(sel), 1):5.1f}%)")
        print(f"{mode:>20}  {cols[0]}   {cols[1]}")


if __name__ == "__main__":
    sys.exit(main())
