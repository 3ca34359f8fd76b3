"""Two faults at once: named as the pair, as unexplained, or as one wrong single fault?

BITs with two parametric faults in different replaceable parts (every such pair of the
dictionary's kinds, magnitudes 35-100 % of range each) and single faults (25-100 %) are flown
at conditions drawn over the actuator's envelope (a quarter on the ground), on the data
sheet's twin or, with ``--units N``, on N units drawn off the data sheet by the mismatch
harness (``mapr_daemon.testbed.mismatch``), each commissioned on ``--commission-bits`` of its
own healthy BITs (``calibrate_unit``, as ``bench/units.py`` does). Every BIT is decided by
``classifier.decide``. Printed per pair: named as the pair, as unexplained, as one of its two
faults alone (the "wrong single" a maintainer would act on and fly the other), as something
else, or missed; the pair members' severity error when the pair is named; and for the single
faults how many were named right, as a pair, or unexplained. The pairs with the SMPS
low-side Ron are on their own rows: the bus barely sees that fault (docs/reasoner-measured.md).

Seeds: a master seed, drawn afresh unless ``--seed`` is given, is printed first; the fleet,
conditions, magnitudes and per-run noise seeds come from it.

Run:  python3 bench/compound.py --dictionary DICT [--actuator FILE] [--per-pair 8]
      [--per-kind 8] [--units 0] [--seed N]
"""

from __future__ import annotations

import argparse
import itertools
import os
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from seeds import master

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.commissioning import calibrate
from mapr_daemon.reasoner.diagnosis import classifier
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.diagnosis.parts import PART_OF
from mapr_daemon.reasoner.training.corpus import simulate_bit
from mapr_daemon.reasoner.training.dictionary_build import run_matrices
from mapr_daemon.testbed.mismatch import fleet

GROUND_SHARE = 0.25
HIDDEN = "smps_ron_low"
"""The fault the bus barely sees: its pairs are reported apart."""
OUTCOMES = ("pair", "unexplained", "one of the two", "other", "missed")


def outcome(truth: set[str], dec: classifier.Decision) -> str:
    """What a maintainer would read of a compound BIT."""
    if not dec.anomaly:
        return "missed"
    if dec.fault is None:
        return "unexplained"
    if dec.pair is not None:
        return "pair" if {m.fault for m in dec.pair} == truth else "other"
    return "one of the two" if dec.fault in truth else "other"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--actuator", type=Path, default=default_actuator_path())
    ap.add_argument("--dictionary", type=Path, required=True)
    ap.add_argument("--per-pair", type=int, default=8, help="BITs per pair (and unit)")
    ap.add_argument("--per-kind", type=int, default=8, help="single-fault BITs per kind")
    ap.add_argument("--units", type=int, default=0, help="mismatched units (0: the twin)")
    ap.add_argument("--commission-bits", type=int, default=20)
    ap.add_argument("--seed", type=int, help="master seed (default: drawn afresh, printed)")
    args = ap.parse_args()
    seed = master(args.seed, f"python3 bench/compound.py --actuator {args.actuator} "
                  f"--dictionary {args.dictionary} --units {args.units}")
    start, cpu0 = time.monotonic(), time.process_time()
    sheet = load_actuator(args.actuator)
    d = Dictionary.load(args.dictionary)
    kinds = sorted({t.kind for t in d.templates if not t.switch})
    pairs = [(a, b) for a, b in itertools.combinations(kinds, 2) if PART_OF[a] != PART_OF[b]]
    rng = np.random.default_rng(seed)
    units = fleet(sheet, args.units, int(rng.integers(2**31))) if args.units else []
    env = sheet.envelope
    specs: list[RunSpec] = []
    q: list[float] = []
    who: list[tuple[int, str, dict[str, float]]] = []  # unit (-1 twin), role, truth

    def add(u: int, role: str, truth: dict[str, float]) -> None:
        faults = FaultSet.of([at_severity(sheet, k, s) for k, s in truth.items()])
        kw = {"seed": int(rng.integers(10**9, 2**62)),
              "ambient_c": float(rng.uniform(env.ambient_min_c, env.ambient_max_c)),
              "bus_v": float(rng.uniform(sheet.bus.min_v, sheet.bus.max_v))}
        specs.append(RunSpec(sheet, faults, **kw) if u < 0 else units[u].spec(faults, **kw))
        q.append(0.0 if rng.random() < GROUND_SHARE
                 else float(rng.uniform(0.0, env.max_dynamic_pressure_pa)))
        who.append((u, role, truth))

    for u in range(len(units)) if units else [-1]:
        if u >= 0:
            for _ in range(args.commission_bits):
                add(u, "commission", {})
        for a, b in pairs:
            for _ in range(args.per_pair):
                sa, sb = rng.uniform(0.35, 1.0, 2)
                add(u, "pair", {a: float(sa), b: float(sb)})
        for k in kinds:
            for _ in range(args.per_kind):
                add(u, "single", {k: float(rng.uniform(0.25, 1.0))})
    t0 = time.monotonic()
    runs = simulate_bit(sheet, [], q, [], specs=specs)
    m = run_matrices(runs, d.window_starts, d.window_samples, d.signals)
    print(f"{sheet.name}: {len(specs)} BITs simulated in {time.monotonic() - t0:.1f} s "
          f"({'the data sheet twin' if not units else f'{len(units)} mismatched units'})")
    t0 = time.monotonic()
    decs: dict[int, classifier.Decision] = {}
    for u in range(len(units)) if units else [-1]:
        own = [i for i, w in enumerate(who) if w[0] == u]
        base = d
        if u >= 0:
            comm = [i for i in own if who[i][1] == "commission"]
            base, _ = calibrate.calibrate_unit(d, m[comm], np.asarray(q)[comm])
        for i in own:
            if who[i][1] != "commission":
                decs[i] = classifier.decide(base, m[i], q[i])
    print(f"decided in {time.monotonic() - t0:.1f} s")
    report_pairs(pairs, who, decs)
    report_singles(kinds, who, decs)
    print(f"\ntotal wall {time.monotonic() - start:.1f} s, CPU {time.process_time() - cpu0:.1f}"
          f" s; load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


def report_pairs(pairs: list[tuple[str, str]], who: list[tuple[int, str, dict[str, float]]],
                 decs: dict[int, classifier.Decision]) -> None:
    """Per pair the outcomes; totals with and without the hidden fault; pair severity errors."""
    print(f"\n== two faults at once (35-100 % of range each)\n{'pair':>36} {'BITs':>5} "
          + " ".join(f"{o:>15}" for o in OUTCOMES) + f" {'sev err mean/max':>17}")
    totals = {"seen": Counter[str](), "hidden": Counter[str]()}
    for a, b in pairs:
        rows = [i for i, w in enumerate(who) if w[1] == "pair" and set(w[2]) == {a, b}]
        c = Counter(outcome({a, b}, decs[i]) for i in rows)
        err = [abs(mm.severity - who[i][2][mm.fault]) for i in rows
               if outcome({a, b}, decs[i]) == "pair" for mm in decs[i].pair or ()]
        group = "hidden" if HIDDEN in (a, b) else "seen"
        totals[group].update(c)
        totals[group]["n"] += len(rows)
        sev = f"{np.mean(err):.2f}/{np.max(err):.2f}" if err else "-"
        print(f"{a + '+' + b:>36} {len(rows):5d} "
              + " ".join(f"{c[o]:5d} ({100 * c[o] / max(len(rows), 1):5.1f}%)"
                         for o in OUTCOMES) + f" {sev:>17}")
    for group, label in (("seen", "pairs the bus can see"),
                         ("hidden", f"pairs with {HIDDEN}")):
        c = totals[group]
        n = max(c["n"], 1)
        ok = c["pair"] + c["unexplained"]
        print(f"{label:>36} {c['n']:5d} "
              + " ".join(f"{c[o]:5d} ({100 * c[o] / n:5.1f}%)" for o in OUTCOMES)
              + f"   pair or unexplained {100 * ok / n:.1f} %, one wrong single "
                f"{100 * c['one of the two'] / n:.1f} %")


def report_singles(kinds: list[str], who: list[tuple[int, str, dict[str, float]]],
                   decs: dict[int, classifier.Decision]) -> None:
    """Single faults: named right, named as a pair, unexplained, other, missed."""
    print(f"\n== one fault (25-100 % of range)\n{'mode':>36} {'BITs':>5} "
          + " ".join(f"{o:>15}" for o in ("right", "as a pair", "unexplained", "other",
                                          "missed")))
    total = Counter[str]()
    for k in kinds:
        rows = [i for i, w in enumerate(who) if w[1] == "single" and set(w[2]) == {k}]
        c = Counter[str]()
        for i in rows:
            dec = decs[i]
            c["missed" if not dec.anomaly else "unexplained" if dec.fault is None
              else "as a pair" if dec.pair is not None else "right" if dec.fault == k
              else "other"] += 1
        total.update(c)
        total["n"] += len(rows)
        print(f"{k:>36} {len(rows):5d} " + " ".join(
            f"{c[o]:5d} ({100 * c[o] / max(len(rows), 1):5.1f}%)"
            for o in ("right", "as a pair", "unexplained", "other", "missed")))
    n = max(total["n"], 1)
    print(f"{'all':>36} {total['n']:5d} " + " ".join(
        f"{total[o]:5d} ({100 * total[o] / n:5.1f}%)"
        for o in ("right", "as a pair", "unexplained", "other", "missed")))


if __name__ == "__main__":
    sys.exit(main())
