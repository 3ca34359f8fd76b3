"""A unit learned in service: detection, isolation and severity against the healthy BITs seen.

Each of ``--units`` units drawn off the data sheet by the mismatch harness
(``mapr_daemon.testbed.mismatch``) is commissioned on 5 healthy BITs and then flies a stream
of healthy BITs (conditions over the envelope, a quarter on the ground) through
:class:`~mapr_daemon.reasoner.commissioning.in_service.InServiceLearning`, which learns from
those its guard lets through and calibrates the unit afresh at 5, 10, 20, 50, 100 and 200
BITs. After each calibration the unit's held-out BITs are decided with its dictionary of the
moment: ``--healthy`` healthy ones (alarms) and ``--faulted`` per mode (25-100 % of range:
detection, isolation to the part, severity error where the right mode is named). Printed: the
curve over the BITs learned, the worst unit beside the average.

Then the guard against learning a slow fault: ``--drift-units`` units each fly the same kind
of stream while friction grows linearly from nominal to ``--drift-to`` of its range over it,
once through the guarded learner and once through one that learns from every BIT without an
alarm. Printed per learner: where learning stopped (and why), the BIT at which the growing
friction was first flagged, and how many of the stream's last quarter were flagged.

Run:  python3 bench/in_service.py --dictionary DICT [--actuator FILE] [--units 30]
      [--stream 200] [--drift-units 5] [--seed N]
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

from seeds import master

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import SWITCHES, Fault, FaultSet, at_severity
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.commissioning.in_service import SCHEDULE, InServiceLearning
from mapr_daemon.reasoner.diagnosis import classifier, parts
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.training.corpus import simulate_bit
from mapr_daemon.reasoner.training.dictionary_build import run_matrices
from mapr_daemon.testbed.mismatch import Unit, fleet

MODES = ("capacitance", "esr", "smps_ron_high", "smps_ron_low", "inverter_ron_a_high",
         "friction", "short", "open")
HIDDEN = "smps_ron_low"
GROUND_SHARE = 0.25
COMMISSION = 5


class Flights:
    """Draws a unit's BITs (conditions over the envelope) and flies them in one batch."""

    def __init__(self, sheet_path: Path, d: Dictionary, rng: np.random.Generator) -> None:
        self.sheet = load_actuator(sheet_path)
        self.d, self.rng = d, rng

    def fly(self, unit: Unit, faults: list[FaultSet]) -> tuple[np.ndarray, list[float]]:
        env, rng = self.sheet.envelope, self.rng
        specs: list[RunSpec] = []
        q: list[float] = []
        for f in faults:
            specs.append(unit.spec(f, seed=int(rng.integers(10**9, 2**62)),
                                   ambient_c=float(rng.uniform(env.ambient_min_c,
                                                               env.ambient_max_c)),
                                   bus_v=float(rng.uniform(self.sheet.bus.min_v,
                                                           self.sheet.bus.max_v))))
            q.append(0.0 if rng.random() < GROUND_SHARE
                     else float(rng.uniform(0.0, env.max_dynamic_pressure_pa)))
        runs = simulate_bit(self.sheet, [], q, [], specs=specs)
        return run_matrices(runs, self.d.window_starts, self.d.window_samples,
                            self.d.signals), q


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--actuator", type=Path, default=default_actuator_path())
    ap.add_argument("--dictionary", type=Path, required=True)
    ap.add_argument("--units", type=int, default=30)
    ap.add_argument("--stream", type=int, default=200, help="healthy BITs flown per unit")
    ap.add_argument("--healthy", type=int, default=10, help="held-out healthy BITs per unit")
    ap.add_argument("--faulted", type=int, default=2, help="held-out BITs per mode and unit")
    ap.add_argument("--drift-units", type=int, default=5)
    ap.add_argument("--drift-to", type=float, default=0.6)
    ap.add_argument("--seed", type=int, help="master seed (default: drawn afresh, printed)")
    args = ap.parse_args()
    seed = master(args.seed, f"python3 bench/in_service.py --actuator {args.actuator} "
                  f"--dictionary {args.dictionary} --units {args.units}")
    start, cpu0 = time.monotonic(), time.process_time()
    d = Dictionary.load(args.dictionary)
    rng = np.random.default_rng(seed)
    flights = Flights(args.actuator, d, rng)
    sheet = flights.sheet
    units = fleet(sheet, args.units + args.drift_units, int(rng.integers(2**31)))
    checkpoints = [c for c in SCHEDULE if c <= args.stream]
    # per checkpoint, per unit: (healthy alarms, [(mode, magnitude, decision)])
    curve: dict[int, list[tuple[int, list[tuple[str, float, classifier.Decision]]]]] = {
        c: [] for c in checkpoints}
    refused = Counter[str]()
    frozen = Counter[str]()
    for ui in range(args.units):
        unit = units[ui]
        held: list[FaultSet] = [FaultSet()] * args.healthy
        truth: list[tuple[str, float]] = []
        for mode in MODES:
            for _ in range(args.faulted):
                if mode in ("short", "open"):
                    sw = SWITCHES[int(rng.integers(len(SWITCHES)))]
                    held.append(FaultSet.of([Fault(mode, switch=sw)]))
                    truth.append((mode, 1.0))
                else:
                    s = float(rng.uniform(0.25, 1.0))
                    held.append(FaultSet.of([at_severity(sheet, mode, s)]))
                    truth.append((mode, s))
        m_stream, q_stream = flights.fly(unit, [FaultSet()] * args.stream)
        m_held, q_held = flights.fly(unit, held)
        learner = InServiceLearning(d, list(m_stream[:COMMISSION]), list(q_stream[:COMMISSION]))
        done: set[int] = set()
        for i in range(COMMISSION - 1, args.stream):
            if i >= COMMISSION:
                learner.observe(m_stream[i], q_stream[i])
            if learner.bits in checkpoints and learner.bits not in done:
                done.add(learner.bits)
                curve[learner.bits].append(held_out(learner.current, m_held, q_held, truth,
                                                    args.healthy))
        refused.update(learner.refused)
        if learner.frozen is not None:
            frozen[learner.frozen.split(" ", 1)[0]] += 1
    elapsed = time.monotonic() - start
    print(f"{args.units} units of {sheet.name}: {args.stream} healthy BITs streamed each, "
          f"{args.healthy} healthy and {args.faulted} per mode held out ({elapsed:.0f} s)")
    print("not learned from: " + (", ".join(f"{k} {v}" for k, v in refused.most_common())
                                  or "none") + "; units whose learning stopped: "
          + (", ".join(f"{v} ({k} drifting)" for k, v in frozen.items()) or "none"))
    print_curve(curve, args.healthy)
    if args.drift_units:
        drift(units[args.units:], flights, args.stream, args.drift_to)
    print(f"\ntotal wall {time.monotonic() - start:.1f} s, CPU {time.process_time() - cpu0:.1f}"
          f" s; load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


def held_out(d: Dictionary, m: np.ndarray, q: list[float], truth: list[tuple[str, float]],
             healthy: int) -> tuple[int, list[tuple[str, float, classifier.Decision]]]:
    """The unit's held-out BITs decided with its dictionary of the moment: the healthy ones'
    alarms, and each faulted one's (mode, magnitude, decision)."""
    decs = [classifier.decide(d, m[i], q[i]) for i in range(len(q))]
    return (sum(dec.anomaly for dec in decs[:healthy]),
            [(mode, s, dec) for (mode, s), dec in zip(truth, decs[healthy:], strict=True)])


def print_curve(curve: dict[int, list[tuple[int, list[tuple[str, float,
                                                            classifier.Decision]]]]],
                healthy: int) -> None:
    """One row per checkpoint: alarms, detection, part isolation, severity error."""
    print("\n(modes the bus can see: all but smps_ron_low; its own columns at the right)")
    print(f"{'BITs':>5} {'units':>5} {'healthy alarms':>15} {'detected':>9} {'worst unit':>10} "
          f"{'to part':>8} {'worst unit':>10} {'sev err':>8} {'worst':>6} {'low-side det':>12}")
    for c, rows in curve.items():
        if not rows:
            continue
        det_u, part_u, errs = [], [], []
        alarms = sum(a for a, _ in rows)
        low = [dec.anomaly for _, cases in rows for mode, _, dec in cases if mode == HIDDEN]
        for _, cases in rows:
            seen = [(mode, s, dec) for mode, s, dec in cases if mode != HIDDEN]
            det_u.append(np.mean([dec.anomaly for _, _, dec in seen]))
            part_u.append(np.mean([dec.anomaly and parts.same_part(mode, dec.fault)
                                   for mode, _, dec in seen]))
            errs += [abs(dec.severity - s) for mode, s, dec in seen
                     if dec.anomaly and dec.fault == mode and dec.severity is not None]
        print(f"{c:5d} {len(rows):5d} {alarms:6d} of {healthy * len(rows):5d} "
              f"{100 * np.mean(det_u):8.1f}% {100 * min(det_u):9.1f}% "
              f"{100 * np.mean(part_u):7.1f}% {100 * min(part_u):9.1f}% "
              f"{np.mean(errs) if errs else float('nan'):8.3f} "
              f"{max(errs) if errs else float('nan'):6.3f} {100 * np.mean(low):11.1f}%")


def drift(units: list[Unit], flights: Flights, stream: int, to: float) -> None:
    """Friction growing over the stream: the guarded learner against an unguarded one."""
    sheet = flights.sheet
    print(f"\n== friction growing from nominal to {to:.0%} of its range over {stream} BITs "
          f"after {COMMISSION} commissioning BITs ({len(units)} units)")
    print(f"{'learner':>10} {'unit':>5} {'stopped at BIT':>15} {'first flagged at':>17} "
          f"{'last quarter flagged':>21}  why it stopped")
    for ui, unit in enumerate(units):
        sev = np.concatenate([np.zeros(COMMISSION),
                              np.linspace(0.0, to, stream - COMMISSION)])
        faults = [FaultSet() if s == 0.0 else FaultSet.of([at_severity(sheet, "friction", s)])
                  for s in sev]
        m, q = flights.fly(unit, faults)
        for guarded in (True, False):
            lr = InServiceLearning(flights.d, list(m[:COMMISSION]), list(q[:COMMISSION]),
                                   guarded=guarded)
            flagged: list[int] = []
            stopped = None
            for i in range(COMMISSION, stream):
                dec = lr.observe(m[i], q[i])
                if dec.anomaly:
                    flagged.append(i)
                if stopped is None and lr.frozen is not None:
                    stopped = i
            quarter = [i for i in flagged if i >= stream - stream // 4]
            at = f" (friction {sev[flagged[0]]:.2f} at the first flag)" if flagged else ""
            print(f"{'guarded' if guarded else 'unguarded':>10} {ui:5d} "
                  f"{'-' if stopped is None else stopped:>15} "
                  f"{flagged[0] if flagged else '-':>17} "
                  f"{len(quarter):>10} of {stream // 4:<8}  {lr.frozen or ''}{at}")


if __name__ == "__main__":
    sys.exit(main())
