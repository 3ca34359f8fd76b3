"""What the power switches' temperatures give the reasoner: the SMPS low-side Ron over the
envelope with and without them, on seeds drawn afresh at every run.

Two dictionaries are built from one spec (default the demo's smaller one,
configs/reasoner/dictionary-demo.yaml; its design seeds), one as the spec says and one with
``switch_temperatures: true``. Then fresh BITs are flown once and decided by both:

* ``smps_ron_low`` at 25-100 % of its range, ``--per-cell`` BITs in each cell of the detection
  map's grid (3 aircraft-bus bands x 3 ambient bands over the actuator's envelope; dynamic
  pressure over the envelope, a quarter on the ground);
* the other two switches that carry a sensor, ``smps_ron_high`` and ``inverter_ron_a_high``, at
  25-100 %, ``--others`` BITs each over the whole envelope;
* ``--healthy`` healthy BITs over the whole envelope (false alarms).

Printed per cell: detected and isolated (named ``smps_ron_low``) shares, without / with the
switch temperatures, then the mean over the cells and the worst cell; the other modes' shares;
healthy alarms. Inconclusive BITs (bus below the SMPS's headroom) are counted apart.

Seeds: the master seed (drawn from the operating system unless ``--seed``) is printed first;
every condition, magnitude and per-run noise seed comes from it (per-run seeds in 10^9..2^62,
clear of the dictionaries' design seeds, which start at the spec's ``seed_base``).

Run:  nice -n 5 python3 bench/switch_temperatures.py [--seed N] [--per-cell 20]
      [--others 60] [--healthy 300] [--spec FILE]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from seeds import master

from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.reasoner.diagnosis import classifier, detection_map
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary, DictionarySpec
from mapr_daemon.reasoner.training.corpus import simulate_bit
from mapr_daemon.reasoner.training.dictionary_build import build, run_matrices

ROOT = Path(__file__).resolve().parents[1]
MODE = "smps_ron_low"
OTHERS = ("smps_ron_high", "inverter_ron_a_high")
GROUND_SHARE = 0.25


@dataclasses.dataclass
class Plan:
    """Every fresh BIT: its faults, truth (mode or ""), cell (bus band, ambient band; -1 for
    BITs drawn over the whole envelope), pressure, ambient, bus mean and seed."""

    faults: list[FaultSet] = dataclasses.field(default_factory=list)
    mode: list[str] = dataclasses.field(default_factory=list)
    cell: list[tuple[int, int]] = dataclasses.field(default_factory=list)
    q: list[float] = dataclasses.field(default_factory=list)
    amb: list[float] = dataclasses.field(default_factory=list)
    bus: list[float] = dataclasses.field(default_factory=list)
    seeds: list[int] = dataclasses.field(default_factory=list)


def plan(params: ActuatorParams, rng: np.random.Generator, per_cell: int, others: int,
         healthy: int) -> Plan:
    env = params.envelope
    bus_edges = detection_map.band_edges(params.bus.min_v, params.bus.max_v)
    amb_edges = detection_map.band_edges(env.ambient_min_c, env.ambient_max_c)
    p = Plan()

    def add(faults: FaultSet, mode: str, cell: tuple[int, int], t: float, v: float) -> None:
        q = 0.0 if rng.random() < GROUND_SHARE else float(rng.uniform(
            0.0, env.max_dynamic_pressure_pa))
        p.faults.append(faults)
        p.mode.append(mode)
        p.cell.append(cell)
        p.q.append(q)
        p.amb.append(t)
        p.bus.append(v)
        p.seeds.append(int(rng.integers(10**9, 2**62)))

    def severity(kind: str) -> FaultSet:
        return FaultSet.of([at_severity(params, kind, float(rng.uniform(0.25, 1.0)))])

    for i in range(len(bus_edges) - 1):
        for j in range(len(amb_edges) - 1):
            for _ in range(per_cell):
                add(severity(MODE), MODE, (i, j),
                    float(rng.uniform(amb_edges[j], amb_edges[j + 1])),
                    float(rng.uniform(bus_edges[i], bus_edges[i + 1])))
    whole = [(kind, others) for kind in OTHERS] + [("", healthy)]
    for kind, n in whole:
        for _ in range(n):
            add(severity(kind) if kind else FaultSet(), kind, (-1, -1),
                float(rng.uniform(env.ambient_min_c, env.ambient_max_c)),
                float(rng.uniform(params.bus.min_v, params.bus.max_v)))
    return p


def decide(d: Dictionary, p: Plan, runs: object) -> list[classifier.Decision]:
    m = run_matrices(runs, d.window_starts, d.window_samples, d.signals)  # type: ignore[arg-type]
    return [classifier.decide(d, m[i], p.q[i]) for i in range(len(p.q))]


def shares(p: Plan, dec: list[classifier.Decision], rows: list[int],
           mode: str) -> tuple[int, int, int]:
    """(conclusive BITs, detected, isolated to ``mode``) among ``rows``."""
    ok = [i for i in rows if "inconclusive" not in dec[i].evidence]
    det = sum(bool(dec[i].anomaly) for i in ok)
    iso = sum(bool(dec[i].anomaly) and dec[i].fault == mode for i in ok)
    return len(ok), det, iso


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, help="master seed (default: drawn afresh, printed)")
    ap.add_argument("--per-cell", type=int, default=20, help="smps_ron_low BITs per cell")
    ap.add_argument("--others", type=int, default=60, help="BITs per other switch mode")
    ap.add_argument("--healthy", type=int, default=300, help="healthy BITs")
    ap.add_argument("--spec", type=Path, default=ROOT / "configs/reasoner/dictionary-demo.yaml")
    args = ap.parse_args()
    spec_path = args.spec.resolve()
    shown = spec_path.relative_to(ROOT) if spec_path.is_relative_to(ROOT) else spec_path
    seed = master(args.seed, f"python3 bench/switch_temperatures.py --per-cell {args.per_cell} "
                             f"--others {args.others} --healthy {args.healthy} "
                             f"--spec {shown}")
    wall0, cpu0 = time.monotonic(), time.process_time()
    params = load_actuator(default_actuator_path())
    spec = DictionarySpec.load(args.spec)
    ds: dict[bool, Dictionary] = {}
    for sw in (False, True):
        t0 = time.monotonic()
        ds[sw] = build(params, dataclasses.replace(spec, switch_temperatures=sw))
        print(f"dictionary {'with' if sw else 'without'} switch temperatures: "
              f"{len(ds[sw].columns)} columns, built in {time.monotonic() - t0:.0f} s")
    p = plan(params, np.random.default_rng(seed), args.per_cell, args.others, args.healthy)
    t0 = time.monotonic()
    runs = simulate_bit(params, p.faults, p.q, p.seeds, ambient_c=p.amb, bus_v=p.bus)
    decisions = {sw: decide(d, p, runs) for sw, d in ds.items()}
    print(f"{len(p.q)} fresh BITs flown and decided by both in {time.monotonic() - t0:.0f} s")
    report(params, p, decisions)
    print(f"\ntotal wall {time.monotonic() - wall0:.0f} s, CPU {time.process_time() - cpu0:.0f} s"
          f" (this process; the build's and the flights' worker threads included); load "
          f"average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


def report(params: ActuatorParams, p: Plan,
           decisions: dict[bool, list[classifier.Decision]]) -> None:
    bus_edges = detection_map.band_edges(params.bus.min_v, params.bus.max_v)
    amb_edges = detection_map.band_edges(params.envelope.ambient_min_c,
                                         params.envelope.ambient_max_c)
    print(f"\n== {MODE} at 25-100 % of range, per cell: detected / isolated "
          "(without -> with the switch temperatures)")
    print(f"{'bus V':>13} {'ambient C':>13} {'BITs':>5} {'detected %':>15} {'isolated %':>15}")
    per_cell: dict[bool, list[tuple[float, float]]] = {False: [], True: []}
    for i in range(len(bus_edges) - 1):
        for j in range(len(amb_edges) - 1):
            rows = [k for k, c in enumerate(p.cell) if c == (i, j)]
            cols = []
            for sw in (False, True):
                n, det, iso = shares(p, decisions[sw], rows, MODE)
                per_cell[sw].append((det / max(n, 1), iso / max(n, 1)))
                cols.append((n, det, iso))
            (n0, d0, i0), (_, d1, i1) = cols
            print(f"{bus_edges[i]:5.1f}-{bus_edges[i + 1]:5.1f}  "
                  f"{amb_edges[j]:5.0f}-{amb_edges[j + 1]:5.0f}  {n0:5d} "
                  f"{100 * d0 / max(n0, 1):6.1f} -> {100 * d1 / max(n0, 1):5.1f} "
                  f"{100 * i0 / max(n0, 1):6.1f} -> {100 * i1 / max(n0, 1):5.1f}")
    for label, k in (("detected", 0), ("isolated", 1)):
        a = [100 * x[k] for x in per_cell[False]]
        b = [100 * x[k] for x in per_cell[True]]
        print(f"{label}: mean over cells {np.mean(a):5.1f} % -> {np.mean(b):5.1f} %, "
              f"worst cell {min(a):5.1f} % -> {min(b):5.1f} %, best cell {max(a):5.1f} % -> "
              f"{max(b):5.1f} %")
    print("\n== the other switches with a sensor, 25-100 % over the envelope")
    for mode in OTHERS:
        rows = [k for k, m in enumerate(p.mode) if m == mode]
        out = []
        for sw in (False, True):
            n, det, iso = shares(p, decisions[sw], rows, mode)
            out.append(f"{100 * det / max(n, 1):5.1f} % / {100 * iso / max(n, 1):5.1f} %")
        print(f"{mode:>20} ({len(rows)} BITs) detected / isolated: {out[0]}  ->  {out[1]}")
    rows = [k for k, m in enumerate(p.mode) if not m]
    print(f"\n== healthy BITs over the envelope ({len(rows)})")
    for sw in (False, True):
        dec = decisions[sw]
        alarms = [k for k in rows if dec[k].anomaly]
        inconc = sum("inconclusive" in dec[k].evidence for k in rows)
        worst = max(dec[k].score / dec[k].threshold for k in rows)
        named = sorted({dec[k].fault or "unexplained" for k in alarms})
        print(f"{'with' if sw else 'without'} switch temperatures: {len(alarms)} alarms "
              f"({', '.join(named) or 'none'}), {inconc} inconclusive, largest score / "
              f"threshold {worst:.2f}")


if __name__ == "__main__":
    sys.exit(main())
