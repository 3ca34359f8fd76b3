"""The reasoner on actuators that are not its model's twin, commissioned from their own BITs.

A fleet of units is drawn off the actuator file (``mapr_daemon.testbed.mismatch``: parameters
by part-to-part tolerance, and a model form the data sheet does not carry — stiction, discrete
or voltage-mode control, a housekeeping load, a Hall offset, sensor gain and offset errors).
Each unit flies ``--commission-bits`` healthy BITs at conditions drawn over the envelope; the
data sheet's dictionary is calibrated to the unit on them
(:func:`mapr_daemon.reasoner.commissioning.calibrate.calibrate_unit`); then the unit's other BITs
are
diagnosed: ``--healthy`` healthy ones and two faulted ones per mode (magnitudes 25-100 % of
range for the parametric modes, short/open on a random switch), all at conditions drawn over
the whole envelope (a quarter on the ground). The same BITs are also decided with the
uncalibrated dictionary, for comparison.

With ``--identify`` each unit is commissioned as ``mapr commission`` does it: its parameters
identified from the same BITs (:func:`mapr_daemon.reasoner.commissioning.identify.identify`), a
dictionary
built on the identified actuator (``--spec``, default the shipped one), then calibrated to
the unit; slower (a dictionary per unit).

With ``--baseline`` each unit is also commissioned as ``mapr commission`` does it for the
baseline reading: its parameters identified from the same BITs and the model's discrepancy
learned on them (:func:`mapr_daemon.reasoner.commissioning.discrepancy.learn_unit`), and the
unit's own anomaly detector calibrated on them read held out
(:func:`mapr_daemon.reasoner.commissioning.detector.calibrate`). Every diagnosed BIT is then
read against the baseline (:meth:`mapr_daemon.reasoner.reasoner.Reasoner.baseline_reading`) and
decided by :func:`mapr_daemon.reasoner.commissioning.detection.decide` under each of its rules:
``dictionary`` (the dictionary detects, the reading weighs in on what it flags: the product
before the detector, and for a record without one), ``union``, ``explained`` (the product's
rule, what the daemon does for an asset with ``commissioned:``) and ``baseline``; one table
each, and one more for rule ``explained`` with the decision's older rule on the reading (a
fault's leftover judged as a share of the departure, without the unit's single-fault
allowance), on the same readings. ``--dump FILE`` writes each diagnosed BIT's detection
statistics, its unit's thresholds and the dictionary's alarm as JSON lines, to read other rules
off the same BITs. The CPU time of each reading and of each unit's detector calibration is
printed (mean and worst), and how the healthy BITs' two detection statistics sit against their
unit's thresholds.

Every faulted BIT is also flown on the data sheet's exact twin (the same fault, magnitude,
condition and noise seed, the data sheet's parameters and the plant's own form) and decided
by the data sheet's dictionary: the exact model's ceiling, printed last, and per table the
detection and part among the BITs the twin's dictionary detected (what commissioning can be
held to: a non-twin unit does not see what the exact model cannot). Each table also gives the
per-mode figures where the dictionary's detection map says the bus can see the mode.
``--twins`` draws units that are the data sheet's exact twins instead of mismatched ones (the
bench's own ceiling for the commissioning path: 20 BITs, the calibration and the reading).
Each unit's visibility is measured on its commissioning BITs and calibrated dictionary as
``mapr commission`` does (:func:`mapr_daemon.reasoner.commissioning.visibility.measure`): its
floor per mode is printed, and each table gives per mode the detection above and below the
unit's floor, and the detection the measured shares predicted beside the one found.

Seeds: a master seed, drawn afresh unless ``--seed`` is given, is printed first; the fleet,
conditions, magnitudes and per-run noise seeds (10^9..2^62) come from it.

Run:  python3 bench/units.py --actuator FILE --dictionary DICT [--units 30]
      [--commission-bits 20] [--healthy 20] [--seed N] [--baseline]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
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
from mapr_daemon.ema.form import ModelForm
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.errors import ConfigError
from mapr_daemon.reasoner.commissioning import calibrate, detection, detector, visibility
from mapr_daemon.reasoner.commissioning.baseline import Baseline
from mapr_daemon.reasoner.commissioning.bits import from_runs
from mapr_daemon.reasoner.commissioning.discrepancy import learn_unit
from mapr_daemon.reasoner.commissioning.friction_law import identify_with_law
from mapr_daemon.reasoner.commissioning.identify import FitOptions, identify
from mapr_daemon.reasoner.commissioning.severity import Reading
from mapr_daemon.reasoner.commissioning.unit_decision import explains, verdict
from mapr_daemon.reasoner.diagnosis import classifier, parts
from mapr_daemon.reasoner.diagnosis.dictionary import Dictionary, DictionarySpec
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training.corpus import Runs, simulate_bit
from mapr_daemon.reasoner.training.dictionary_build import build, run_matrices
from mapr_daemon.testbed.mismatch import fleet, twin

MODES = ("capacitance", "esr", "smps_ron_high", "smps_ron_low", "inverter_ron_a_high",
         "friction", "short", "open")
GROUND_SHARE = 0.25


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--actuator", type=Path, default=default_actuator_path())
    ap.add_argument("--dictionary", type=Path, required=True,
                    help="the data sheet's dictionary (mapr dictionary build --actuator ...)")
    ap.add_argument("--units", type=int, default=30)
    ap.add_argument("--commission-bits", type=int, default=20)
    ap.add_argument("--healthy", type=int, default=20, help="healthy BITs per unit diagnosed")
    ap.add_argument("--faulted", type=int, default=2, help="faulted BITs per mode and unit")
    ap.add_argument("--seed", type=int, help="master seed (default: drawn afresh, printed)")
    ap.add_argument("--identify", action="store_true",
                    help="identify each unit and build its dictionary before calibrating")
    ap.add_argument("--spec", type=Path, help="dictionary spec for --identify")
    ap.add_argument("--baseline", action="store_true",
                    help="also identify each unit, learn its discrepancy and decide with the "
                         "reading against its baseline (the daemon's assets[].commissioned)")
    ap.add_argument("--friction-law", action="store_true",
                    help="with --baseline: identify as `mapr commission --friction-law` does "
                         "(the friction law chosen from the BITs, the parameters bounded)")
    ap.add_argument("--twins", action="store_true",
                    help="units that are the data sheet's exact twins (no tolerance, no model "
                         "form): what the bench allows when the model is exact")
    ap.add_argument("--dump", type=Path,
                    help="with --baseline: each diagnosed BIT's detection statistics as JSON "
                         "lines")
    args = ap.parse_args()
    # every option that changes what is flown or how it is decided, so the rerun is this run
    seed = master(args.seed, f"python3 bench/units.py --actuator {args.actuator} "
                  f"--dictionary {args.dictionary} --units {args.units} "
                  f"--commission-bits {args.commission_bits} --healthy {args.healthy} "
                  f"--faulted {args.faulted}"
                  + (" --identify" if args.identify else "")
                  + (f" --spec {args.spec}" if args.spec is not None else "")
                  + (" --baseline" if args.baseline else "")
                  + (" --friction-law" if args.friction_law else "")
                  + (" --twins" if args.twins else ""))
    start, cpu0 = time.monotonic(), time.process_time()
    sheet = load_actuator(args.actuator)
    d = Dictionary.load(args.dictionary)
    if abs(d.sample_rate_hz - sheet.sensors.sample_rate_hz) > 1e-9:
        # the BITs are flown at the actuator's rate: a dictionary built at another reads
        # every one of them wrong (and the baseline reading refuses them all)
        print(f"{args.dictionary}: built at {d.sample_rate_hz:g} Hz, {args.actuator} flies at "
              f"{sheet.sensors.sample_rate_hz:g} Hz; build one at the actuator's rate "
              f"(mapr dictionary build --actuator {args.actuator})", file=sys.stderr)
        return 2
    rng = np.random.default_rng(seed)
    units = fleet(sheet, args.units, int(rng.integers(2**31)))
    if args.twins:
        units = [twin(sheet, u.seed) for u in units]
    env = sheet.envelope
    specs: list[RunSpec] = []
    q: list[float] = []
    who: list[tuple[int, str, str, float]] = []  # unit, role, mode, magnitude
    blind: list[list[str]] = []  # the modes the dictionary's map calls blind at the BIT's condition

    def add(u: int, role: str, faults: FaultSet, mode: str, mag: float) -> None:
        p = 0.0 if rng.random() < GROUND_SHARE else float(
            rng.uniform(0.0, env.max_dynamic_pressure_pa))
        amb = float(rng.uniform(env.ambient_min_c, env.ambient_max_c))
        bus = float(rng.uniform(sheet.bus.min_v, sheet.bus.max_v))
        specs.append(units[u].spec(faults, seed=int(rng.integers(10**9, 2**62)), ambient_c=amb,
                                   bus_v=bus))
        q.append(p)
        who.append((u, role, mode, mag))
        blind.append([] if d.detection is None else d.detection.blind(bus, amb))

    for u in range(len(units)):
        for _ in range(args.commission_bits):
            add(u, "commission", FaultSet(), "", 0.0)
        for _ in range(args.healthy):
            add(u, "healthy", FaultSet(), "", 0.0)
        for mode in MODES:
            for _ in range(args.faulted):
                if mode in ("short", "open"):
                    sw = SWITCHES[int(rng.integers(len(SWITCHES)))]
                    add(u, "faulted", FaultSet.of([Fault(mode, switch=sw)]), mode, 1.0)
                else:
                    s = float(rng.uniform(0.25, 1.0))
                    add(u, "faulted", FaultSet.of([at_severity(sheet, mode, s)]), mode, s)
    t0 = time.monotonic()
    runs = simulate_bit(sheet, [], q, [], specs=specs)
    m = run_matrices(runs, d.window_starts, d.window_samples, d.signals)
    # the same faulted BITs (fault, magnitude, condition, noise seed) flown on the data
    # sheet's exact twin and decided by its own dictionary: what the exact model sees of them
    paired = [i for i, w in enumerate(who) if w[1] == "faulted"]
    twin_runs = simulate_bit(sheet, [], [q[i] for i in paired], [], specs=[
        dataclasses.replace(specs[i], params=sheet, form=ModelForm()) for i in paired])
    twin_m = run_matrices(twin_runs, d.window_starts, d.window_samples, d.signals)
    twin_sees = [False] * len(who)
    twin_decs: list[tuple[tuple[int, str, str, float], classifier.Decision]] = []
    for j, i in enumerate(paired):
        twin_decs.append((who[i], classifier.decide(d, twin_m[j], q[i])))
        twin_sees[i] = twin_decs[-1][1].anomaly
    t_sim = time.monotonic() - t0
    print(f"{len(units)} units of {sheet.name}, {len(specs)} BITs simulated in {t_sim:.1f} s "
          f"({args.commission_bits} commissioning BITs per unit)")
    before: list[classifier.Decision | None] = []
    after: list[classifier.Decision | None] = []
    by_rule: dict[str, list[classifier.Decision | None]] = {r: [] for r in detection.RULES}
    older: list[classifier.Decision | None] = []  # rule explained, the older decision
    read_cpu: list[float] = []
    calib_cpu: list[float] = []
    healthy_reads: list[tuple[bool, float]] = []  # explains, cost drop
    over: dict[str, list[float]] = {k: [] for k in detector.STATISTICS}  # healthy value/thr
    dumped: list[dict[str, object]] = []
    t_commission = 0.0
    unit_vis: list[visibility.Visibility] = []
    vis_cpu: list[float] = []
    widened: list[int] = []
    raised: dict[str, list[float]] = {}
    t0 = time.monotonic()
    for u in range(len(units)):
        own = [i for i, w in enumerate(who) if w[0] == u]
        comm = [i for i in own if who[i][1] == "commission"]
        base, model = d, sheet
        if args.identify:
            base, model = _identified(sheet, runs, comm, args.spec)
        unit_d, report = calibrate.calibrate_unit(base, m[comm], np.asarray(q)[comm])
        bl = None
        widened.append(report.widened_cells)
        for stat, (old, new) in report.thresholds.items():
            raised.setdefault(stat, []).append(new / old)
        reasoner = None
        if args.baseline:
            tc = time.monotonic()
            bl, cpu = _baseline(sheet, runs, comm, args.friction_law)
            calib_cpu.append(cpu)
            reasoner = Reasoner(unit_d, sheet, baseline=bl)
            t_commission += time.monotonic() - tc
            thr = "none" if bl.detector is None else ", ".join(
                f"{k} {t.threshold:.3g}" for k, t in bl.detector.tails.items())
            al = _allowance(bl)
            thr += ("; no single-fault allowance" if al is None else
                    f"; a single fault may leave {al.healthy:.2f} + {al.share:.3f} x what it "
                    f"explains, per mode " + ", ".join(f"{k} {v:.3f}" for k, v in al.shares.items())
                    + f" ({sum(map(len, al.excess.values()))} added faults)")
            law = bl.params.motor.breakaway_ratio
            print(f"  unit {u + 1}/{len(units)}: identified (friction law "
                  + (f"stiction {law:g} x Coulomb" if law > 0.0 else "smoothed") + "), "
                  f"discrepancy learned and detector "
                  f"calibrated in {time.monotonic() - tc:.1f} s (detector {cpu:.1f} s CPU; "
                  f"thresholds {thr}; wall {time.monotonic() - start:.0f} s so far)",
                  flush=True)
        cv = time.process_time()
        # the departures flown on the identified model where there is one, as mapr commission
        try:
            seen = visibility.measure(
                unit_d, model if bl is None else bl.params, from_runs(runs, "bench", comm),
                held_out=calibrate.without_each(base, m[comm], np.asarray(q)[comm]))
        except ConfigError:   # every commissioning BIT alarmed or was inconclusive
            seen = visibility.Visibility(visibility.SEVERITIES, {}, 1)
        vis_cpu.append(time.process_time() - cv)
        unit_vis.append(seen)
        print(f"    unit {u + 1}: what its BITs can see, floor per mode ({vis_cpu[-1]:.1f} s "
              f"CPU; {seen.alarmed} of its healthy BITs alarmed held out): "
              + ", ".join(f"{k} " + ("never" if seen.floor(k) is None else
                                     f"{seen.floor(k):.0%}") for k in seen.detected),
              flush=True)
        for i in own:
            if who[i][1] == "commission":
                continue
            before.append(classifier.decide(d, m[i], q[i]))
            dec = classifier.decide(unit_d, m[i], q[i])
            after.append(dec)
            if reasoner is None:
                continue
            assert reasoner.baseline is not None
            channels = {k: v[i] for k, v in runs.channels.items()}
            c0 = time.process_time()
            r = reasoner.baseline_reading(channels, runs.command_deg, q[i])
            read_cpu.append(time.process_time() - c0)
            for rule in detection.RULES:
                by_rule[rule].append(detection.decide(dec, r, reasoner.baseline, rule))
            older.append(detection.decide(dec, r, _older(reasoner.baseline)))
            if args.dump is not None:
                dumped.append(_dump(who[i], dec, r, reasoner.baseline))
            if who[i][1] == "healthy" and isinstance(r, Reading):
                healthy_reads.append((explains(r, _allowance(reasoner.baseline)),
                                      r.healthy_cost - r.cost))
                if reasoner.baseline.detector is not None:
                    st = detector.statistics(r)
                    for k, t in reasoner.baseline.detector.tails.items():
                        over[k].append(st[k] / t.threshold)
    print(f"calibrated and decided in {time.monotonic() - t0:.1f} s; cells widened > 2x per "
          f"unit: median {int(np.median(widened))}, max {max(widened)}; thresholds raised by "
          + ", ".join(f"{k} x{np.median(v):.2f} median, x{max(v):.2f} max"
                      for k, v in raised.items()))
    scored = [w for w in who if w[1] != "commission"]
    scored_blind = [b for w, b in zip(who, blind, strict=True) if w[1] != "commission"]
    scored_twin = [t for w, t in zip(who, twin_sees, strict=True) if w[1] != "commission"]
    blocks = [("the data sheet's dictionary", before), ("calibrated to each unit", after)]
    if args.baseline:
        blocks.append(("calibrated to each unit + the reading against its baseline, the "
                       "dictionary detecting (rule dictionary: before the unit's detector)",
                       by_rule["dictionary"]))
        blocks.append(("calibrated to each unit + the unit's detector, either firing "
                       "(rule union)", by_rule["union"]))
        blocks.append(("rule explained with the older decision on the reading (a fault's "
                       "leftover as a share of the departure, no single-fault allowance: the "
                       "product's default, assets[].commissioned)", older))
        blocks.append(("calibrated to each unit + the unit's detector's GLRT statistic "
                       "(rule explained; the reading within the unit's single-fault allowance, "
                       "mapr commission --single-allowance)", by_rule["explained"]))
        blocks.append(("the unit's detector on the baseline reading deciding alone "
                       "(rule baseline)", by_rule["baseline"]))
        drops = [x for _, x in healthy_reads]
        print(f"baseline: identified + discrepancy learned + detector calibrated in "
              f"{t_commission:.1f} s wall for {len(units)} units (detector calibration CPU per "
              f"unit mean {np.mean(calib_cpu):.1f} s, worst {max(calib_cpu):.1f} s); "
              f"{len(read_cpu)} BITs read against it, CPU per reading mean "
              f"{np.mean(read_cpu) if read_cpu else 0:.2f} s, worst "
              f"{max(read_cpu, default=0.0):.2f} s; {len(healthy_reads)} healthy BITs read: "
              f"{sum(e for e, _ in healthy_reads)} would be explained as a fault, cost drop "
              f"median {np.median(drops) if drops else 0:.2f}, largest "
              f"{max(drops, default=0.0):.2f}")
        for k, v in over.items():
            if v:
                print(f"  healthy BITs' {k} / the unit's threshold: median {np.median(v):.2f},"
                      f" largest {max(v):.2f}; above it {sum(x > 1.0 for x in v)} of {len(v)}")
    for name, decs in blocks:
        report_block(name, scored, decs, scored_blind, scored_twin, unit_vis)
    product = older if args.baseline else after
    print("\n== per unit: its own healthy BITs flagged at commissioning by the dictionary "
          "calibrated without each (what mapr commission warns of) against its healthy BITs "
          "flagged after, by the product")
    for u, seen in enumerate(unit_vis):
        flagged = [dec is not None and dec.anomaly for w, dec in zip(scored, product, strict=True)
                   if w[0] == u and w[1] == "healthy"]
        print(f"  unit {u + 1}: {seen.alarmed} of {seen.alarmed + seen.bits} at commissioning; "
              f"{sum(flagged)} of {len(flagged)} after")
    print("\n== the same faulted BITs flown on the data sheet's exact twin, decided by its own "
          "dictionary (the exact model's ceiling): BITs, detected, to the part, severity error "
          "mean/max where the mode was named")
    for mode in MODES:
        cell = [(w, dec) for w, dec in twin_decs if w[2] == mode]
        err = [abs(dec.severity - w[3]) for w, dec in cell
               if dec.anomaly and dec.fault == mode and dec.severity is not None]
        sev = f"{np.mean(err):.3f}/{np.max(err):.3f}" if err else "-"
        print(f"{mode:>20} {_seen_row(cell)}   {sev}")
    others = [(w, dec) for w, dec in twin_decs if w[2] != "smps_ron_low"]
    print(f"{'all but smps_ron_low':>20} {_seen_row(others)}")
    if args.dump is not None:
        args.dump.write_text("".join(json.dumps(x) + "\n" for x in dumped))
    print(f"\ntotal wall {time.monotonic() - start:.1f} s, CPU {time.process_time() - cpu0:.1f}"
          f" s; load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


def _dump(w: tuple[int, str, str, float], dec: classifier.Decision, r: Reading | str,
          bl: Baseline) -> dict[str, object]:
    """One diagnosed BIT for ``--dump``."""
    out: dict[str, object] = {"unit": w[0], "role": w[1], "mode": w[2], "magnitude": w[3],
                              "dictionary": dec.anomaly, "dictionary_fault": dec.fault}
    if isinstance(r, Reading):
        out.update(reading=r.mode, severity=r.severity,
                   explains=explains(r, _allowance(bl)), cost=r.cost,
                   pair_cost=None if r.pair is None else r.pair.cost,
                   verdict=verdict(r, _allowance(bl)), **detector.statistics(r))
    if bl.detector is not None:
        out["thresholds"] = {k: t.threshold for k, t in bl.detector.tails.items()}
    return out


def _older(bl: Baseline) -> Baseline:
    """``bl`` without its single-fault allowance: the decision's older rule."""
    if bl.detector is None:
        return bl
    return dataclasses.replace(bl, detector=dataclasses.replace(bl.detector, allowance=None))


def _allowance(bl: Baseline) -> detector.Allowance | None:
    return None if bl.detector is None else bl.detector.allowance


def _baseline(sheet: ActuatorParams, runs: Runs, comm: list[int], friction_law: bool = False
              ) -> tuple[Baseline, float]:
    """The unit's commissioned baseline as ``mapr commission`` writes it: the actuator
    identified from ``comm``, the discrepancy learned on the BITs the identification used and
    the unit's detector calibrated on them (fault ranges on the data sheet); and the
    detector's calibration CPU seconds. ``friction_law``: as ``mapr commission
    --friction-law`` identifies."""
    bits = from_runs(runs, "bench", comm)
    ident = identify_with_law(sheet, bits) if friction_law else identify(sheet, bits)
    used = [b for b in bits if b.index in {u.index for u in ident.bits}]
    disc = learn_unit(ident.params, used, FitOptions().decimate)
    c0 = time.process_time()
    det = detector.calibrate(ident.params, sheet, disc, used)
    return Baseline(ident.params, sheet, disc, det), time.process_time() - c0


def _identified(sheet: ActuatorParams, runs: Runs, comm: list[int],
                spec_path: Path | None) -> tuple[Dictionary, ActuatorParams]:
    """The dictionary ``mapr commission`` builds and the actuator it is built on, the one
    identified from ``comm``."""
    root = Path(__file__).resolve().parents[1]
    spec = DictionarySpec.load(spec_path or root / "configs/reasoner/dictionary.yaml")
    ident = identify(sheet, from_runs(runs, "bench", comm))
    return build(ident.params, spec), ident.params


def report_block(name: str, who: list[tuple[int, str, str, float]],
                 decs: list[classifier.Decision | None], blind: list[list[str]],
                 twin_sees: list[bool], unit_vis: list[visibility.Visibility]) -> None:
    """Healthy alarms (overall, worst unit), per mode detection and isolation, the same
    where the data sheet's detection map says the bus can see the mode (``blind``: per BIT
    the modes the map calls blind at its condition), and among the faulted BITs whose twin
    (the same fault, magnitude, condition and noise on the data sheet's exact model) its own
    dictionary detected (``twin_sees``), and above each unit's own floor (``unit_vis``, what
    its commissioning measured its BITs can see), with the detection the floor's shares
    predicted beside the one found."""
    print(f"\n== {name}")
    healthy = [(w[0], dec) for w, dec in zip(who, decs, strict=True) if w[1] == "healthy"]
    alarms = Counter(u for u, dec in healthy if dec is not None and dec.anomaly)
    n_units = len({u for u, _ in healthy})
    print(f"healthy BITs: {sum(alarms.values())} alarms in {len(healthy)} "
          f"({sum(1 for c in alarms.values() if c)} of {n_units} units alarmed at least once; "
          f"worst unit {max(alarms.values()) if alarms else 0} of "
          f"{len(healthy) // max(n_units, 1)})")
    named = Counter(dec.fault or "unexplained" for _, dec in healthy
                    if dec is not None and dec.anomaly)
    if named:
        print("  named: " + ", ".join(f"{k} {v}" for k, v in named.most_common()))
    print(f"{'mode':>20} {'BITs':>5} {'detected':>14} {'isolated':>14} {'to part':>14} "
          f"{'unexplained':>14} {'wrong part':>14} {'sev err mean/max':>17}")
    tot = Counter[str]()
    errors: list[float] = []
    for mode in MODES:
        pairs = [(w, dec) for w, dec in zip(who, decs, strict=True) if w[2] == mode and dec]
        rows = [dec for _, dec in pairs]
        det = sum(d.anomaly for d in rows)
        iso = sum(d.anomaly and d.fault == mode for d in rows)
        part = sum(d.anomaly and parts.same_part(mode, d.fault) for d in rows)
        unexplained = sum(d.anomaly and d.fault is None for d in rows)
        wrong = det - part - unexplained
        # severity error where the right mode was named (a fraction of the Table 1 range)
        err = [abs(d.severity - w[3]) for w, d in pairs
               if d.anomaly and d.fault == mode and d.severity is not None]
        if mode != "smps_ron_low":
            errors += err
        n = max(len(rows), 1)
        sev = f"{np.mean(err):.3f}/{np.max(err):.3f}" if err else "-"
        print(f"{mode:>20} {len(rows):5d} {det:5d} ({100 * det / n:5.1f}%) {iso:5d} "
              f"({100 * iso / n:5.1f}%) {part:5d} ({100 * part / n:5.1f}%) {unexplained:5d} "
              f"({100 * unexplained / n:5.1f}%) {wrong:5d} ({100 * wrong / n:5.1f}%) {sev:>17}")
        tot.update(n=len(rows), det=det, iso=iso, part=part, unexplained=unexplained,
                   wrong=wrong)
        if mode != "smps_ron_low":
            tot.update(n_seen=len(rows), det_seen=det, part_seen=part)
    n = max(tot["n"], 1)
    sev = f"{np.mean(errors):.3f}/{np.max(errors):.3f}" if errors else "-"
    print(f"{'all modes':>20} {tot['n']:5d} {tot['det']:5d} ({100 * tot['det'] / n:5.1f}%) "
          f"{tot['iso']:5d} ({100 * tot['iso'] / n:5.1f}%) {tot['part']:5d} "
          f"({100 * tot['part'] / n:5.1f}%) {tot['unexplained']:5d} "
          f"({100 * tot['unexplained'] / n:5.1f}%) {tot['wrong']:5d} "
          f"({100 * tot['wrong'] / n:5.1f}%) {sev:>17}")
    low = [(w, dec) for w, dec in zip(who, decs, strict=True)
           if w[2] == "smps_ron_low" and dec is not None]
    seen = [dec for _, dec in low if "smps_ron_low" not in
            dec.evidence.get("not_observable_here", {}).get("faults", [])]
    if low:
        print(f"{'smps_ron_low':>20} where the dictionary's detection map says the bus can see "
              f"it: {sum(d.anomaly for d in seen)} of {len(seen)} detected "
              f"({len(low) - len(seen)} of {len(low)} BITs flown where it is blind)")
    visible = [(w, dec) for w, dec, b in zip(who, decs, blind, strict=True)
               if w[1] == "faulted" and dec is not None and w[2] not in b]
    _subset("where the detection map says the bus can see the mode: BITs, detected, to the "
            "part (and BITs flown where it is blind)", who, visible, "blind",
            "visible, all modes")
    seen_by_twin = [(w, dec) for w, dec, t in zip(who, decs, twin_sees, strict=True)
                    if w[1] == "faulted" and dec is not None and t]
    _subset("the faulted BITs whose exact twin its own dictionary detected: BITs, detected, "
            "to the part (and the twin's misses)", who, seen_by_twin, "twin missed",
            "seen by the twin")
    others = [(w, dec) for w, dec in seen_by_twin if w[2] != "smps_ron_low"]
    if others:
        print(f"{'... but smps_ron_low':>20} {_seen_row(others)}")
    faulted = [(w, dec) for w, dec in zip(who, decs, strict=True)
               if w[1] == "faulted" and dec is not None and w[2] in unit_vis[w[0]].detected]
    if faulted:
        print("  above each unit's own floor (what its commissioning measured its BITs can "
              "see): BITs, detected, to the part; below it: BITs, detected; detection the "
              "unit's measured shares predicted / found, all BITs")
        for mode in MODES:
            cell = [(w, dec) for w, dec in faulted if w[2] == mode]
            if not cell:
                continue
            above = [(w, dec) for w, dec in cell if unit_vis[w[0]].sees(mode, w[3])]
            below = [dec.anomaly for w, dec in cell if not unit_vis[w[0]].sees(mode, w[3])]
            said = np.mean([unit_vis[w[0]].share_at(mode, w[3]) for w, _ in cell])
            found = np.mean([dec.anomaly for _, dec in cell])
            print(f"{mode:>20} " + (_seen_row(above) if above else f"{0:5d}" + " " * 34)
                  + f"   below {len(below):3d} {sum(below):3d}   predicted {100 * said:5.1f}% "
                  f"found {100 * found:5.1f}%")
        above = [(w, dec) for w, dec in faulted if w[2] != "smps_ron_low"
                 and unit_vis[w[0]].sees(w[2], w[3])]
        if above:
            print(f"{'above, all but low':>20} {_seen_row(above)}")
    ns = max(tot["n_seen"], 1)
    print(f"{'all but smps_ron_low':>20} {tot['n_seen']:5d} {tot['det_seen']:5d} "
          f"({100 * tot['det_seen'] / ns:5.1f}%) {'':>14} {tot['part_seen']:5d} "
          f"({100 * tot['part_seen'] / ns:5.1f}%)   severity error over the parametric modes "
          f"named right: mean {sev.split('/')[0]}, worst {sev.split('/')[-1]} of range")


def _subset(title: str, who: list[tuple[int, str, str, float]],
            kept: list[tuple[tuple[int, str, str, float], classifier.Decision]], left: str,
            total: str) -> None:
    """Per mode and in all, BITs, detected and to the part among the faulted BITs ``kept``,
    with how many of the mode's were left out (``left`` names why)."""
    if not kept:
        return
    print(f"  {title}")
    for mode in MODES:
        cell = [(w, dec) for w, dec in kept if w[2] == mode]
        flown = sum(1 for w in who if w[1] == "faulted" and w[2] == mode)
        if cell:
            print(f"{mode:>20} {_seen_row(cell)}   {left} {flown - len(cell)}")
    print(f"{total:>20} {_seen_row(kept)}")


def _seen_row(rows: list[tuple[tuple[int, str, str, float], classifier.Decision]]) -> str:
    """BITs, detected and named to the part, as a table row's cells."""
    det = sum(d.anomaly for _, d in rows)
    part = sum(d.anomaly and parts.same_part(w[2], d.fault) for w, d in rows)
    n = len(rows)
    return f"{n:5d} {det:5d} ({100 * det / n:5.1f}%) {part:5d} ({100 * part / n:5.1f}%)"


if __name__ == "__main__":
    sys.exit(main())
