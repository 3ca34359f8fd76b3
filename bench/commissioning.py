"""How many healthy BITs commissioning needs: identification error against the number of BITs.

Units are drawn off the aileron data sheet (configs/actuators/aileron-uav.yaml) by part-to-
part tolerance, each parameter uniform in its band (:data:`UNIT_BANDS`, percent):

    winding R +-10, back-EMF constant +-5, winding L +-20, inertia +-15, viscous and Coulomb
    friction +-40 (each its own draw), gear efficiency +-5, SMPS L +-20, C -10/+20, ESR +-30

Each unit flies :data:`MAX_BITS` healthy BITs in the full plant (sensor noise, friction
scatter, bus drift and ripple), each at its own random condition in the envelope: dynamic
pressure 0..2500 Pa, ambient -40..70 C, aircraft bus 22..29 V (uniform). Commissioning
(:func:`mapr_daemon.reasoner.commissioning.identify.identify`, the shipped tolerances) then sees
the data
sheet and the unit's first n BITs, n in :data:`COUNTS`. Printed per parameter and n: the RMS
and the worst identification error over the units (log ratio of identified to true, in %),
how many units found it identifiable, and the median and worst |error|/sd (1 = the reported
sd is right).

The unit's source is one function (:func:`simulated_unit`): anything that returns the true
parameter values and a :class:`~mapr_daemon.reasoner.training.corpus.Runs` of its healthy BITs (a
plant of another model form, say) can be scored by :func:`score_unit` the same way.

Run: ``python3 bench/commissioning.py [--units 6] [--seed S] [--counts 1,2,5,10,20]``; the
seed is drawn afresh unless given, and printed.
"""

from __future__ import annotations

import argparse
import math
import os
import time
from collections.abc import Sequence

import numpy as np

from mapr_daemon.ema.faults import FaultSet
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.reasoner.commissioning import prior as ip
from mapr_daemon.reasoner.commissioning.bits import from_runs
from mapr_daemon.reasoner.commissioning.identify import Identification, identify
from mapr_daemon.reasoner.training.corpus import Runs, simulate_bit

UNIT_BANDS: dict[str, tuple[float, float]] = {
    "motor.resistance_ohm": (-10, 10), "motor.back_emf_v_s_per_rad": (-5, 5),
    "motor.inductance_h": (-20, 20), "motor.inertia_kg_m2": (-15, 15),
    "motor.viscous_friction_nm_s": (-40, 40), "motor.coulomb_friction_nm": (-40, 40),
    "gear.efficiency": (-5, 5), "smps.inductance_h": (-20, 20),
    "smps.capacitance_f": (-10, 20), "smps.esr_ohm": (-30, 30),
}
COUNTS = (1, 2, 5, 10, 20)
FRICTION = ("motor.viscous_friction_nm_s", "motor.coulomb_friction_nm")
BOTH = "friction (both terms)"
MAX_BITS = 20


def simulated_unit(datasheet: ActuatorParams, rng: np.random.Generator, n_bits: int
                   ) -> tuple[dict[str, float], Runs]:
    """A unit drawn by tolerance and its healthy BITs at random envelope conditions."""
    factors = {p: 1.0 + rng.uniform(lo, hi) / 100.0 for p, (lo, hi) in UNIT_BANDS.items()}
    unit = ip.scaled(datasheet, factors)
    q = rng.uniform(0.0, 2500.0, n_bits)
    amb = rng.uniform(-40.0, 70.0, n_bits)
    bus = rng.uniform(22.0, 29.0, n_bits)
    seeds = rng.integers(0, 2**31, n_bits)
    runs = simulate_bit(unit, [FaultSet()] * n_bits, list(q), [int(s) for s in seeds],
                        ambient_c=list(amb), bus_v=list(bus))
    return {p: ip.get(unit, p) for p in UNIT_BANDS}, runs


def score_unit(datasheet: ActuatorParams, truth: dict[str, float], runs: Runs,
               counts: Sequence[int]) -> dict[int, Identification]:
    """Identify from the first n BITs of ``runs`` for each n of ``counts``."""
    out = {}
    for n in counts:
        bits = from_runs(runs, "unit", list(range(min(n, runs.n))))
        out[n] = identify(datasheet, bits)
    return out


def _errors(ident: Identification, truth: dict[str, float]) -> dict[str, tuple[float, float,
                                                                             bool]]:
    """Per parameter: error (log ratio), error / reported sd, identifiable."""
    out = {}
    for e in ident.estimates:
        if e.path in truth:
            err = math.log(e.fitted / truth[e.path])
            out[e.path] = (err, err / max(e.sd_rel, 1e-12), e.identifiable)
    paths = [e.path for e in ident.estimates]
    if all(f in out for f in FRICTION):
        # the friction fault scales both terms: their geometric mean is what it moves
        j, k = (paths.index(f) for f in FRICTION)
        sv, sc = ident.estimates[j].sd_rel, ident.estimates[k].sd_rel
        sd = 0.5 * math.sqrt(sv**2 + sc**2 + 2 * ident.correlation[j][k] * sv * sc)
        err = 0.5 * (out[FRICTION[0]][0] + out[FRICTION[1]][0])
        out[BOTH] = (err, err / sd, out[FRICTION[0]][2] and out[FRICTION[1]][2])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--units", type=int, default=6)
    ap.add_argument("--seed", type=int)
    ap.add_argument("--counts", default=",".join(str(c) for c in COUNTS))
    args = ap.parse_args()
    counts = [int(c) for c in args.counts.split(",")]
    seed = int(np.random.SeedSequence().entropy % 2**32) if args.seed is None else args.seed
    print(f"seed {seed} (units {args.units}, BITs per unit {max(counts)}); "
          f"machine: {os.cpu_count()} cores, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())} at start")
    datasheet = load_actuator(default_actuator_path())
    wall0, cpu0 = time.monotonic(), time.process_time()
    table: dict[int, list[dict[str, tuple[float, float, bool]]]] = {n: [] for n in counts}
    fit_s: dict[int, list[float]] = {n: [] for n in counts}
    rng = np.random.default_rng(seed)
    for u in range(args.units):
        truth, runs = simulated_unit(datasheet, rng, max(counts))
        for n, ident in score_unit(datasheet, truth, runs, counts).items():
            table[n].append(_errors(ident, truth))
            fit_s[n].append(ident.wall_s)
            skipped = f", skipped {len(ident.skipped)}" if ident.skipped else ""
            print(f"unit {u} n={n}: {ident.model_runs} model runs, {ident.wall_s:.1f} s"
                  f"{skipped}", flush=True)
    wall, cpu = time.monotonic() - wall0, time.process_time() - cpu0
    print()
    print("identification error, % (log ratio identified/true): RMS over units / worst; "
          "[units identifiable]; median and worst |error|/sd")
    print(f"{'parameter':<28}" + "".join(f"{'n=' + str(n):>26}" for n in counts))
    for path in (*UNIT_BANDS, BOTH):
        cells = []
        for n in counts:
            rows = [t[path] for t in table[n] if path in t]
            if not rows:
                continue
            err = np.array([r[0] for r in rows]) * 100.0
            z = np.abs([r[1] for r in rows])
            ok = sum(r[2] for r in rows)
            cells.append(f"{math.sqrt(np.mean(err**2)):5.2f}/{np.max(np.abs(err)):5.2f} [{ok}] "
                         f"{np.median(z):4.1f} {np.max(z):5.1f}")
        print(f"{path:<28}" + "".join(f"{c:>26}" for c in cells))
    print()
    print("fit wall time per unit, s (mean / worst): "
          + ", ".join(f"n={n}: {np.mean(fit_s[n]):.1f} / {np.max(fit_s[n]):.1f}" for n in counts))
    print(f"total: wall {wall:.0f} s, CPU {cpu:.0f} s; load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())} at end; seed {seed}")


if __name__ == "__main__":
    main()
