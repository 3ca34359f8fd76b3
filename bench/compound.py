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

With ``--baseline`` (needs ``--units``) each unit is also commissioned as ``mapr commission``
does it (``bench/units.py``'s ``--baseline``: its parameters identified from the same healthy
BITs and the model's discrepancy learned on them), and every BIT the calibrated dictionary
flags goes through the product's path (the reading against the unit's baseline, single faults
and pairs, decided by ``detection.decide`` as ``Reasoner.against_baseline`` does); a third pair
of tables gives those decisions, a second the same readings under the older rule (a fault's
leftover judged as a share of the departure, no single-fault allowance), and the CPU time of
each reading (mean and worst) is printed. ``--healthy-reads N`` healthy BITs per unit are read
against the baseline whatever the dictionary says, and what the rule would make of them is
printed (what a healthy BIT leaves, and what a second fault gains on it by chance). ``--dump
FILE`` writes one JSON line per scored BIT (unit, truth, the decisions, the reading's costs):
what a decision rule is chosen on, on design seeds.

Seeds: a master seed, drawn afresh unless ``--seed`` is given, is printed first; the fleet,
conditions, magnitudes and per-run noise seeds come from it.

Run:  python3 bench/compound.py --dictionary DICT [--actuator FILE] [--per-pair 8]
      [--per-kind 8] [--units 0] [--seed N] [--baseline [--dump FILE]]
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import os
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from seeds import master
from units import _baseline as commissioned_baseline

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.faults import FaultSet, at_severity
from mapr_daemon.ema.params import default_actuator_path, load_actuator
from mapr_daemon.reasoner.commissioning import calibrate, detection
from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.unit_decision import verdict
from mapr_daemon.reasoner.diagnosis import classifier
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary
from mapr_daemon.reasoner.diagnosis.parts import PART_OF
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training.corpus import simulate_bit
from mapr_daemon.reasoner.training.dictionary_build import run_matrices
from mapr_daemon.testbed.mismatch import fleet

GROUND_SHARE = 0.25
HIDDEN = "smps_ron_low"
"""The fault the bus barely sees: its pairs are reported apart."""
OUTCOMES = ("pair", "unexplained", "one of the two", "wrong single", "other pair", "missed")
"""A compound BIT named as its pair, as unexplained, as one of its two faults alone (right
about one part, silent about the other), as a single fault that is neither, as another pair,
or not at all."""


def outcome(truth: set[str], dec: classifier.Decision) -> str:
    """What a maintainer would read of a compound BIT."""
    if not dec.anomaly:
        return "missed"
    if dec.fault is None:
        return "unexplained"
    if dec.pair is not None:
        return "pair" if {m.fault for m in dec.pair} == truth else "other pair"
    return "one of the two" if dec.fault in truth else "wrong single"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--actuator", type=Path, default=default_actuator_path())
    ap.add_argument("--dictionary", type=Path, required=True)
    ap.add_argument("--per-pair", type=int, default=8, help="BITs per pair (and unit)")
    ap.add_argument("--per-kind", type=int, default=8, help="single-fault BITs per kind")
    ap.add_argument("--units", type=int, default=0, help="mismatched units (0: the twin)")
    ap.add_argument("--commission-bits", type=int, default=20)
    ap.add_argument("--seed", type=int, help="master seed (default: drawn afresh, printed)")
    ap.add_argument("--baseline", action="store_true",
                    help="also commission each unit's baseline and decide flagged BITs with "
                         "the reading against it (needs --units)")
    ap.add_argument("--healthy-reads", type=int, default=2,
                    help="with --baseline: healthy BITs per unit read against the baseline "
                         "whatever the dictionary says")
    ap.add_argument("--dump", type=Path, help="with --baseline: one JSON line per scored BIT")
    args = ap.parse_args()
    if args.baseline and not args.units:
        ap.error("--baseline needs --units (mismatched units to commission)")
    seed = master(args.seed, f"python3 bench/compound.py --actuator {args.actuator} "
                  f"--dictionary {args.dictionary} --units {args.units} --per-pair "
                  f"{args.per_pair} --per-kind {args.per_kind}"
                  + (f" --baseline --healthy-reads {args.healthy_reads}" if args.baseline
                     else ""))
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
        run_seed = int(rng.integers(10**9, 2**62))
        amb = float(rng.uniform(env.ambient_min_c, env.ambient_max_c))
        bus = float(rng.uniform(sheet.bus.min_v, sheet.bus.max_v))
        specs.append(RunSpec(sheet, faults, seed=run_seed, ambient_c=amb, bus_v=bus) if u < 0
                     else units[u].spec(faults, seed=run_seed, ambient_c=amb, bus_v=bus))
        q.append(0.0 if rng.random() < GROUND_SHARE
                 else float(rng.uniform(0.0, env.max_dynamic_pressure_pa)))
        who.append((u, role, truth))

    for u in range(len(units)) if units else [-1]:
        if u >= 0:
            for _ in range(args.commission_bits):
                add(u, "commission", {})
            if args.baseline:
                for _ in range(args.healthy_reads):
                    add(u, "healthy", {})
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
    with_base: dict[int, classifier.Decision] = {}
    with_older: dict[int, classifier.Decision] = {}  # the same readings, the older rule
    read_cpu: list[float] = []
    healthy: list[tuple[str, float]] = []  # verdict and cost of healthy BITs, read regardless
    dump = args.dump.open("w") if args.dump else None
    for u in range(len(units)) if units else [-1]:
        own = [i for i, w in enumerate(who) if w[0] == u]
        base = d
        reasoner = None
        if u >= 0:
            comm = [i for i in own if who[i][1] == "commission"]
            base, _ = calibrate.calibrate_unit(d, m[comm], np.asarray(q)[comm])
            if args.baseline:
                tc = time.monotonic()
                bl, _ = commissioned_baseline(sheet, runs, comm)
                reasoner = Reasoner(base, sheet, baseline=bl)
                al = None if bl.detector is None else bl.detector.allowance
                print("  " + ("no single-fault allowance" if al is None else
                              f"a single fault may leave {al.healthy:.2f} + {al.share:.3f} x "
                              f"what it explains, per mode "
                              + ", ".join(f"{k} {v:.3f}" for k, v in al.shares.items())
                              + f" ({sum(map(len, al.excess.values()))} added faults)"))
                if dump is not None and al is not None:
                    dump.write(json.dumps({"unit": u, "role": "allowance",
                                           **al.to_json()}) + "\n")
                print(f"  unit {u + 1}/{len(units)}: identified and discrepancy learned in "
                      f"{time.monotonic() - tc:.1f} s (wall {time.monotonic() - start:.0f} s "
                      f"so far)", flush=True)
        for i in own:
            if who[i][1] == "commission":
                continue
            if who[i][1] == "healthy":
                assert reasoner is not None and reasoner.baseline is not None
                channels = {k: v[i] for k, v in runs.channels.items()}
                r = reasoner.baseline.read(channels, runs.command_deg, q[i])
                allowance = (None if reasoner.baseline.detector is None
                             else reasoner.baseline.detector.allowance)
                healthy.append((verdict(r, allowance), 0.0 if isinstance(r, str) else r.cost))
                if dump is not None:
                    dump.write(json.dumps({"unit": u, "role": "healthy", "verdict": healthy[-1][0],
                                           "baseline": reasoner.baseline.to_json(r)}) + "\n")
                continue
            decs[i] = dec = classifier.decide(base, m[i], q[i])
            if reasoner is None:
                continue
            if dec.anomaly and not dec.inconclusive:
                channels = {k: v[i] for k, v in runs.channels.items()}
                c0 = time.process_time()
                reading = reasoner.baseline_reading(channels, runs.command_deg, q[i])
                read_cpu.append(time.process_time() - c0)
                assert reasoner.baseline is not None
                with_older[i] = detection.decide(dec, reading, _older(reasoner.baseline))
                dec = detection.decide(dec, reading, reasoner.baseline)
            else:
                with_older[i] = dec
            with_base[i] = dec
            if dump is not None:
                dump.write(json.dumps(_record(who[i], q[i], decs[i], dec)) + "\n")
    if dump is not None:
        dump.close()
    print(f"decided in {time.monotonic() - t0:.1f} s")
    blocks = [("the dictionary, calibrated to each unit" if units else "the dictionary",
               decs)]
    if args.baseline:
        blocks.append(("+ the reading against each unit's baseline, the older rule (shares of "
                       "the departure, no single-fault allowance: the product's default)",
                       with_older))
        blocks.append(("+ the reading against each unit's baseline (single faults and pairs, "
                       "within the unit's single-fault allowance: mapr commission "
                       "--single-allowance)", with_base))
        print(f"{len(read_cpu)} flagged BITs read against the baseline: CPU per reading mean "
              f"{np.mean(read_cpu) if read_cpu else 0:.2f} s, worst "
              f"{max(read_cpu, default=0.0):.2f} s")
        costs = [c for _, c in healthy]
        said = Counter(v for v, _ in healthy)
        print(f"{len(healthy)} healthy BITs read against the baseline whatever the dictionary "
              f"said: cost median {np.median(costs) if costs else 0:.2f}, largest "
              f"{max(costs, default=0.0):.2f} (healthy spreads squared); the rule's verdict as "
              f"if flagged: {said['pair']} a pair, {said['single']} a single fault, "
              f"{said['unexplained']} unexplained, {said['dictionary']} left to the dictionary")
    for name, block in blocks:
        print(f"\n######## {name}")
        report_pairs(pairs, who, block)
        report_singles(kinds, who, block)
    if args.baseline:
        split = Counter((who[i][1], "disagreement" in d.evidence) for i, d in with_base.items()
                        if d.anomaly and d.fault is not None and d.pair is None
                        and d.evidence.get("reading") == "baseline")
        print(f"\nnamed one fault from the baseline while the dictionary named another part: "
              f"{split[('pair', True)]} of {split[('pair', True)] + split[('pair', False)]} "
              f"compound BITs so named, {split[('single', True)]} of "
              f"{split[('single', True)] + split[('single', False)]} single faults")
    print(f"\ntotal wall {time.monotonic() - start:.1f} s, CPU {time.process_time() - cpu0:.1f}"
          f" s; load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


def _older(bl: Baseline) -> Baseline:
    """``bl`` without its single-fault allowance: the decision's older rule."""
    if bl.detector is None:
        return bl
    return dataclasses.replace(bl, detector=dataclasses.replace(bl.detector, allowance=None))


def _record(w: tuple[int, str, dict[str, float]], q: float, dictionary: classifier.Decision,
            dec: classifier.Decision) -> dict[str, object]:
    """One scored BIT for ``--dump``: its truth, both decisions and the baseline reading."""
    def brief(x: classifier.Decision) -> dict[str, object]:
        return {"anomaly": x.anomaly, "fault": x.fault, "severity": x.severity,
                "pair": None if x.pair is None else [[m.fault, m.severity] for m in x.pair]}
    return {"unit": w[0], "role": w[1], "truth": w[2], "q": q, "dictionary": brief(dictionary),
            "decision": brief(dec), "baseline": dec.evidence.get("baseline")}


def report_pairs(pairs: list[tuple[str, str]], who: list[tuple[int, str, dict[str, float]]],
                 decs: dict[int, classifier.Decision]) -> None:
    """Per pair the outcomes; totals with and without the hidden fault; pair severity errors."""
    print(f"\n== two faults at once (35-100 % of range each; the severity error of a pair named"
          f" right is each member's, fraction of range)\n{'pair':>36} {'BITs':>5} "
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
              + f"   pair or unexplained {100 * ok / n:.1f} %, a single fault (one of the two"
                f" or neither) {100 * (c['one of the two'] + c['wrong single']) / n:.1f} %")


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
