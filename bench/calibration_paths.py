"""Why a fleet's per-BIT degradation estimates differ from what the prognostic model's own
calibration says: the bus path against direct simulation, and the calibration at flight
conditions.

    python3 bench/calibration_paths.py paired --run DIR --run-seed S [--units-per-kind 2]
                                       [--healthy-units 2] [--bit-every 4] [--kinds K,...]
                                       [--compare P2.npz]
    python3 bench/calibration_paths.py levels --dictionary D.npz --prognosis P.npz
                                       [--compare P2.npz] [--reps 30] [--seed N]

``paired`` reads a kept run of ``bench/fleet_rul.py --out DIR`` (its ``fleet.db``, and the
dictionary and prognostic model named in its ``mapr.yaml``), rebuilds every BIT flight's
fault, seed and named condition from the run seed as the bench drew them, and flies each BIT
again directly (:func:`~mapr_daemon.reasoner.training.dictionary_build.stream_matrices`, the model
build's way)
with the same fault, pressure and plant seed: the plant then draws the same ambient and bus.
Printed: how the catalog's stored condition and raw estimate differ from the direct BIT's
(the bus path: ICD scaling, record assembly, sample timing, the pressure the BIT is told), and
per kind and degradation bin the calibrated error of both against the truth, beside the sd
the model states (``--compare``: read through a second model too; its estimators must be the
same).

``levels`` flies fresh BITs at the calibration levels (``--reps`` per level and kind, seeds
drawn from the printed run seed above 10^9), once the way a flight flies them (the named
conditions' pressures, ambient and bus the plant's own flight-to-flight draw: what the
testbed's aircraft does) and once over the envelope (as the model's calibration BITs were
drawn before ``BuildSpec.flight_share``), and prints per kind: the mean raw estimate per level
(flight), and per model the reading's bias per level and per named condition (flight), and
for both draws the error sd, the median stated sd, the rms of error/stated sd and the share
outside the stated 90 % band (10 % if calibrated).
"""

from __future__ import annotations

import argparse
import sqlite3
import sys
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from fleet_rul import HEALTHY, KINDS, SEED_BASE, Unit
from seeds import fresh

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mapr_daemon.catalog.history import load_bits
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.ema.profile import CONDITIONS
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.prognosis import wear_estimators
from mapr_daemon.reasoner.prognosis.prognostic_model import PrognosticModel
from mapr_daemon.reasoner.prognosis.soh import degradation
from mapr_daemon.reasoner.training.corpus import BitRuns
from mapr_daemon.reasoner.training.dictionary_build import stream_matrices
from mapr_daemon.reasoner.training.prognosis_build import conditions, fault_at
from mapr_daemon.reasoner.training.rul_scoring import CALIBRATION_LEVELS

BINS = ((-0.1, 0.1), (0.1, 0.3), (0.3, 0.5), (0.5, 0.7), (0.7, 0.9), (0.9, 1.2))
Z90 = 1.645


def read(model: PrognosticModel, kind: str, est: np.ndarray, cond: list[dict[str, float]],
         h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(calibrated error, stated sd) of raw estimates at their stored conditions."""
    rows = np.array([model.scaled(c) or (np.nan,) * 3 for c in cond])
    noise = model.noise[kind]
    return noise.calibrate(est, rows) - h, noise.h_sd(np.maximum(h, 0.0), rows)


def summary(e: np.ndarray, sd: np.ndarray) -> str:
    z = e / sd
    return (f"bias {e.mean():+.3f} sd {e.std():.3f} stated {np.median(sd):.3f} "
            f"rms z {np.sqrt(np.mean(z * z)):.2f} out90 {100 * np.mean(np.abs(z) > Z90):.0f}%")


def paired(args: argparse.Namespace) -> None:
    run = Path(args.run)
    config = yaml.safe_load((run / "mapr.yaml").read_text(encoding="utf-8"))
    d = Dictionary.load(config["reasoner"]["dictionary"])
    models = {"model": PrognosticModel.load(config["assets"][0]["prognosis"])}
    if args.compare:
        models["compare"] = PrognosticModel.load(args.compare)
    params = load_actuator(default_actuator_path())
    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()]
    rng = np.random.default_rng(args.run_seed)
    units = [Unit(f"U{i + 1:02d}", k, int(rng.integers(SEED_BASE, 2 * SEED_BASE)),
                  args.bit_every) for i, k in enumerate(
                      [*(k for k in kinds for _ in range(args.units_per_kind)),
                       *[HEALTHY] * args.healthy_units])]
    names = sorted(CONDITIONS)
    plan: dict[tuple[str, int], tuple[Unit, int, int, str]] = {}
    for u in units:   # the bench draws each flight's seed, then its condition, unit by unit
        for f in u.flights:
            seed = int(rng.integers(SEED_BASE, 2 * SEED_BASE))
            plan[(u.tail, f + 1)] = (u, f, seed, names[int(rng.integers(len(names)))])
    conn = sqlite3.connect(run / "fleet.db")
    todo = [(plan[(u.tail, b.flight)], b) for u in units if u.kind != HEALTHY
            for b in load_bits(conn, tail=u.tail)
            if b.flight is not None and b.wear and (u.tail, b.flight) in plan]
    print(f"run {run}: seed {args.run_seed}, {len(todo)} BITs of aging units re-flown directly")
    q = [CONDITIONS[c].dynamic_pressure_pa for (_, _, _, c), _ in todo]
    runs = BitRuns.of([u.faults(f) for (u, f, _, _), _ in todo], q,
                      [s for (_, _, s, _), _ in todo])
    m = stream_matrices(params, runs, d.window_starts, d.window_samples)
    direct_est = [models["model"].estimates(d, m[i], q[i]) for i in range(len(todo))]
    direct_cond = [PrognosticModel.bit_conditions(d, m[i], q[i]) for i in range(len(todo))]
    cat_cond = [b.conditions for _, b in todo]
    delta = {k: np.array([c[k] - dc[k] for c, dc in zip(cat_cond, direct_cond, strict=True)])
             for k in ("dynamic_pressure_pa", "supply_v", "ambient_c")}
    print("stored condition minus the direct BIT's: " + "; ".join(
        f"{k} mean {v.mean():+.3f} sd {v.std():.3f} max |.| {np.abs(v).max():.3f}"
        for k, v in delta.items()))
    for kind in kinds:
        idx = [i for i, ((u, _, _, _), _) in enumerate(todo) if u.kind == kind]
        if not idx:
            continue
        h = np.array([degradation(params, kind, float(todo[i][0][0].path.values[todo[i][0][1]]))
                      for i in idx])
        cat = np.array([todo[i][1].wear[kind] for i in idx])
        dire = np.array([direct_est[i][kind] for i in idx])
        print(f"\n{kind}: {len(idx)} BITs; raw estimate, catalog minus direct: mean "
              f"{np.mean(cat - dire):+.4f} sd {np.std(cat - dire):.4f} "
              f"(correlation {np.corrcoef(cat, dire)[0, 1]:.3f})")
        for name, model in models.items():
            ec, sdc = read(model, kind, cat, [cat_cond[i] for i in idx], h)
            ed, sdd = read(model, kind, dire, [direct_cond[i] for i in idx], h)
            print(f"  {name}: catalog {summary(ec, sdc)} | direct {summary(ed, sdd)}")
            for lo, hi in BINS:
                s = (h >= lo) & (h < hi)
                if s.any():
                    print(f"    h in [{lo:.1f},{hi:.1f}) n={s.sum():3d}: catalog "
                          f"{summary(ec[s], sdc[s])} | direct {summary(ed[s], sdd[s])}")


def levels(args: argparse.Namespace) -> None:
    seed = fresh(args.seed)
    params = load_actuator(default_actuator_path())
    d = Dictionary.load(args.dictionary)
    models = {"model": PrognosticModel.load(args.prognosis)}
    if args.compare:
        models["compare"] = PrognosticModel.load(args.compare)
    ref = models["model"]
    rng = np.random.default_rng(seed)
    todo = [(k, h) for k in ref.kinds for h in CALIBRATION_LEVELS for _ in range(args.reps)]
    n = len(todo)
    names = sorted(CONDITIONS)
    qf = [CONDITIONS[names[int(i)]].dynamic_pressure_pa
          for i in rng.integers(len(names), size=n)]
    qe, amb, bus = conditions(params, n, rng, True)
    base = int(rng.integers(SEED_BASE, 2 * SEED_BASE))
    print(f"{args.reps} BITs per level and kind, flight and envelope draws; plant seeds from "
          f"{base}")
    faults = [fault_at(params, k, h) for k, h in todo]
    runs = BitRuns.of(faults + faults, qf + qe, [base + i for i in range(2 * n)],
                      [None] * n + list(amb), [None] * n + list(bus))
    m = stream_matrices(params, runs, d.window_starts, d.window_samples)
    q = np.array(qf + qe)
    y, c = wear_estimators.observations(d, m, list(q))
    cond = [PrognosticModel.bit_conditions(d, m[i], float(q[i])) for i in range(2 * n)]
    truth = np.array([h for _, h in todo] * 2)
    kind_of = np.array([k for k, _ in todo] * 2)
    for kind in ref.kinds:
        rows = np.nonzero(kind_of == kind)[0]
        est = np.array([ref.estimators[kind].estimate(y[i], c[i]) for i in rows])
        h, flight = truth[rows], rows < n
        mean_est = " ".join(f"{v:g}:{est[flight & (h == v)].mean():.3f}"
                            for v in CALIBRATION_LEVELS)
        print(f"\n{kind}: mean raw estimate per level (flight draw) {mean_est}")
        for name, model in models.items():
            if not np.array_equal(model.estimators[kind].coef, ref.estimators[kind].coef):
                print(f"  {name}: other estimators, skipped")
                continue
            e, sd = read(model, kind, est, [cond[i] for i in rows], h)
            lv = " ".join(f"{v:g}:{e[flight & (h == v)].mean():+.3f}" for v in CALIBRATION_LEVELS)
            at = {cn: flight & (q[rows] == CONDITIONS[cn].dynamic_pressure_pa) for cn in names}
            by_q = " ".join(f"{cn} {e[at[cn]].mean():+.3f}" for cn in names)
            print(f"  {name}: flight {summary(e[flight], sd[flight])} | envelope "
                  f"{summary(e[~flight], sd[~flight])}")
            print(f"    bias per level (flight) {lv}")
            print(f"    bias per named condition (flight) {by_q}")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    p = sub.add_parser("paired")
    p.add_argument("--run", required=True)
    p.add_argument("--run-seed", type=int, required=True)
    p.add_argument("--units-per-kind", type=int, default=2)
    p.add_argument("--healthy-units", type=int, default=2)
    p.add_argument("--bit-every", type=int, default=4)
    p.add_argument("--kinds", default=",".join(KINDS))
    p.add_argument("--compare")
    lv = sub.add_parser("levels")
    lv.add_argument("--dictionary", required=True)
    lv.add_argument("--prognosis", required=True)
    lv.add_argument("--compare")
    lv.add_argument("--reps", type=int, default=30)
    lv.add_argument("--seed", type=int)
    args: Any = ap.parse_args(argv)
    (paired if args.what == "paired" else levels)(args)


if __name__ == "__main__":
    main()
