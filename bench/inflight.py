"""In-flight parameter tracking measured: per-flight error against the truth, coverage, cost.

    python3 bench/inflight.py [--units 4] [--scale 1.0] [--commission 3] [--healthy 2]
                              [--seed N]

``--units`` twin units (the actuator file itself) and as many mismatched units
(:func:`mapr_daemon.testbed.mismatch.fleet`) fly whole flights
(:func:`mapr_daemon.testbed.whole_flight.flight_profile`: taxi with the control check, JSBSim
climb, turns and approach, a quiet cruise hold; 255 s of bus at ``--scale 1``), each at its
own ambient temperature (uniform -10..40 C) and aircraft-bus voltage (26-29 V). Every unit is
commissioned on ``--commission`` healthy flights (:func:`mapr_daemon.reasoner.inflight.commission`),
then flies ``--healthy`` healthy flights and, per trended fault mode (friction, phase-A
high-side Ron, ESR), one flight at 0.5 and one at 1.0 of its failure threshold
(:data:`mapr_daemon.ema.degradation.FAILURE`). Flight ``k`` of every unit flies the same
profile (its JSBSim schedule drawn from the master seed); conditions and noise differ per unit.

Per trended parameter, over all evaluation flights (healthy and faulted: a parameter's truth
on a flight with another mode's fault is its own, unchanged part):

* the error of the flight's change against the true change, in units of the mode's failure
  threshold (friction: 2x nominal; phase-A Ron: its nominal; loop R, no fault mode: ohm and
  per cent of the loop), mean, rms and worst;
* coverage of the stated 90 % band (``|change - truth| <= 1.645 sd``);
* false wear: healthy flights whose band lies wholly above the true change (the tracker
  reads wear that is not there; a calibrated band does that on about 5 % of flights), and
  beside it those whose band lies above zero (for friction that is often true: a healthy
  unit's grease scatters 10 % from flight to flight, and the tracker sees it);
* per flight kind, the mean change against the mean true change (both in the unit above);
* the ESR proxy (``bus0``, V/A) has no truth in ohms: its slope against the true ESR change
  is fitted on these flights and the residual sd expressed in ESR thresholds (optimistic:
  the slope is fitted to the same flights).

Cost: the tracker's thread CPU time per flight (real-time factor per actuator, one core),
the plant's and JSBSim's CPU per simulated flight hour.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
import time
from pathlib import Path

import numpy as np
from seeds import master

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mapr_daemon.ema.batch import RunSpec
from mapr_daemon.ema.degradation import FAILURE
from mapr_daemon.ema.faults import Fault, FaultSet
from mapr_daemon.ema.params import ActuatorParams, default_actuator_path, load_actuator
from mapr_daemon.errors import RecordError
from mapr_daemon.reasoner.inflight import (
    FlightEstimate,
    FlightTracker,
    adopt,
    commissioning_values,
)
from mapr_daemon.testbed.mismatch import fleet
from mapr_daemon.testbed.whole_flight import FlightTruth, flight_profile, fly

Z90 = 1.6448536269514722
MODES: tuple[tuple[str, float], ...] = (("friction", 0.5), ("friction", 1.0),
                                        ("inverter_ron_a_high", 0.5),
                                        ("inverter_ron_a_high", 1.0),
                                        ("esr", 0.5), ("esr", 1.0))


@dataclasses.dataclass
class Row:
    group: str
    unit: str
    label: str
    estimate: FlightEstimate | None
    truth: FlightTruth


def fault_at(params: ActuatorParams, kind: str, h: float) -> Fault:
    """``kind`` at ``h`` of the way from the unit's nominal to its failure threshold."""
    nominal = {"friction": 1.0, "inverter_ron_a_high": params.inverter.ron_a_high_ohm,
               "esr": params.smps.esr_ohm}[kind]
    return Fault(kind, nominal * (1.0 + h * (FAILURE[kind] - 1.0)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--units", type=int, default=4)
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--commission", type=int, default=3)
    ap.add_argument("--healthy", type=int, default=2)
    ap.add_argument("--seed", type=int)
    args = ap.parse_args()
    seed = master(args.seed, f"python3 bench/inflight.py --units {args.units} --scale "
                             f"{args.scale:g} --commission {args.commission} "
                             f"--healthy {args.healthy}")
    rng = np.random.default_rng(seed)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    sheet = load_actuator(default_actuator_path())
    rate = sheet.sensors.sample_rate_hz
    mism = fleet(sheet, args.units, seed=int(rng.integers(10**9, 2**62)))
    units: list[tuple[str, str, ActuatorParams, RunSpec]] = []
    for k in range(args.units):
        units.append(("twin", f"twin{k}", sheet, RunSpec(sheet)))
    for k, u in enumerate(mism):
        units.append(("mismatched", f"unit{k}", u.params, u.spec()))
    plan: list[tuple[str, str | None, float]] = (
        [("commission", None, 0.0)] * args.commission + [("healthy", None, 0.0)] * args.healthy
        + [(f"{k}@{h:g}", k, h) for k, h in MODES])
    trackers = {name: FlightTracker(sheet) for _, name, _, _ in units}
    values: dict[str, list[dict[str, float]]] = {name: [] for _, name, _, _ in units}
    truths: dict[str, list[FlightTruth]] = {name: [] for _, name, _, _ in units}
    base: dict[str, FlightTruth] = {}
    rows: list[Row] = []
    plant_cpu = jsb_cpu = 0.0
    bus_s = 0.0
    print(f"{len(units)} units ({args.units} twin, {args.units} mismatched), "
          f"{len(plan)} flights each, {255 * args.scale:.0f} s of bus per flight")
    for fi, (label, kind, h) in enumerate(plan):
        t0 = time.process_time()
        prof = flight_profile(rate, seed=int(rng.integers(1, 2**31)), scale=args.scale)
        jsb_cpu += time.process_time() - t0
        specs = []
        for _, _, params, spec in units:
            faults = FaultSet() if kind is None else FaultSet.of([fault_at(params, kind, h)])
            specs.append(dataclasses.replace(
                spec, faults=faults, seed=int(rng.integers(10**9, 2**62)),
                ambient_c=float(rng.uniform(-10.0, 40.0)), bus_v=float(rng.uniform(26.0, 29.0))))
        t0 = time.process_time()
        flown = fly(specs, prof)
        plant_cpu += time.process_time() - t0
        bus_s += prof.n_samples / rate * len(units)
        q = prof.dynamic_pressure_pa
        for r, (group, name, _, _) in enumerate(units):
            if label == "commission":
                values[name].append(commissioning_values(trackers[name], flown.channels[r], q))
                truths[name].append(flown.truth[r])
                continue
            if name not in base:
                adopt(trackers[name], values[name])
                base[name] = mean_truth(truths[name])
            try:
                est: FlightEstimate | None = trackers[name].track(flown.channels[r], q)
            except RecordError:
                est = None
            rows.append(Row(group, name, label, est, flown.truth[r]))
        del flown
        print(f"  flight {fi + 1}/{len(plan)} ({label}) flown and tracked; "
              f"{time.perf_counter() - wall0:.0f} s wall", flush=True)
    report(rows, sheet, base)
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    tr_cpu = [r.estimate.cpu_s for r in rows if r.estimate is not None]
    tr_rtf = [r.estimate.real_time_factor for r in rows if r.estimate is not None]
    filt = [r.estimate.filtered_s / r.estimate.flight_s for r in rows if r.estimate is not None]
    print(f"\ntracker, per actuator, one core (thread CPU): {np.mean(tr_cpu) * 1e3:.0f} ms per "
          f"{255 * args.scale:.0f} s flight, real-time factor mean {np.mean(tr_rtf):.0f}x, "
          f"worst {np.min(tr_rtf):.0f}x (target >= 100x); filtered {100 * np.mean(filt):.0f} % "
          f"of the bus time (worst {100 * np.max(filt):.0f} %)")
    hours = bus_s / 3600.0
    print(f"cost per simulated flight hour (one actuator, CPU): plant {plant_cpu / hours:.0f} s, "
          f"JSBSim profiles {jsb_cpu / (hours / len(units)):.0f} s per profile-hour (shared by "
          f"the units), tracker {np.sum(tr_cpu) / (len(tr_cpu) * 255 * args.scale / 3600):.0f} s")
    print(f"wall {wall:.0f} s, CPU {cpu:.0f} s, load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")


def mean_truth(t: list[FlightTruth]) -> FlightTruth:
    """The commissioning flights' mean truth (what the baseline stands for)."""
    return FlightTruth(**{f.name: float(np.mean([getattr(x, f.name) for x in t]))
                          for f in dataclasses.fields(FlightTruth)})


def true_change(name: str, t: FlightTruth, b: FlightTruth) -> float:
    """The parameter's true change from the commissioning flights' mean truth."""
    if name == "friction":
        return t.friction_factor / b.friction_factor - 1.0
    if name == "loop_r":
        return t.loop_ohm - b.loop_ohm
    if name == "phase_a_ron":
        return (t.ron_a_high_ohm - t.ron_ohm) - (b.ron_a_high_ohm - b.ron_ohm)
    return t.esr_ohm - b.esr_ohm


def report(rows: list[Row], sheet: ActuatorParams, base: dict[str, FlightTruth]) -> None:
    scale = {"friction": (FAILURE["friction"] - 1.0, "failure thresholds (2.0x nominal)"),
             "phase_a_ron": (sheet.inverter.ron_a_high_ohm,
                             f"failure thresholds ({sheet.inverter.ron_a_high_ohm:g} ohm)"),
             "loop_r": (1.0, "ohm (no fault mode)")}
    missing = sum(r.estimate is None for r in rows)
    print(f"\nevaluation flights: {len(rows)} ({missing} with no qualifying segment)")
    for group in ("twin", "mismatched"):
        sub = [r for r in rows if r.group == group and r.estimate is not None]
        print(f"\n{group} units, {len(sub)} flights")
        for name in ("friction", "loop_r", "phase_a_ron"):
            div, unit = scale[name]
            err, cov, sds, fw, above0, n_h, n = [], [], [], 0, 0, 0, 0
            by_label: dict[str, list[tuple[float, float]]] = {}
            for r in sub:
                assert r.estimate is not None
                tr = r.estimate.parameters.get(name)
                if tr is None:
                    continue
                n += 1
                truth = true_change(name, r.truth, base[r.unit])
                err.append((tr.change - truth) / div)
                sds.append(tr.sd / div)
                cov.append(abs(tr.change - truth) <= Z90 * tr.sd)
                by_label.setdefault(r.label, []).append((tr.change / div, truth / div))
                if r.label == "healthy":
                    n_h += 1
                    fw += tr.change - Z90 * tr.sd > truth
                    above0 += tr.change - Z90 * tr.sd > 0.0
            if not err:
                print(f"  {name}: no estimate on any flight")
                continue
            e = np.array(err)
            print(f"  {name} ({n} flights; error in {unit}): mean {e.mean():+.3f}, rms "
                  f"{np.sqrt(np.mean(e * e)):.3f}, worst {e[np.argmax(np.abs(e))]:+.3f}; stated "
                  f"sd mean {np.mean(sds):.3f}, worst {np.max(sds):.3f}; 90 % band covers "
                  f"{100 * np.mean(cov):.0f} %; false wear on healthy flights {fw}/{n_h} (band "
                  f"above zero {above0}/{n_h})")
            print("    mean change / truth by flight: " + ", ".join(
                f"{k} {np.mean([a for a, _ in v]):+.3f}/{np.mean([b for _, b in v]):+.3f}"
                for k, v in by_label.items()))
        # the ESR proxy: slope of bus0's change on the true ESR change
        pts = [(true_change("esr", r.truth, base[r.unit]), r.estimate.parameters["bus0"])
               for r in sub if r.estimate is not None and "bus0" in r.estimate.parameters]
        if len(pts) >= 3:
            x = np.array([p[0] for p in pts])
            y = np.array([p[1].change for p in pts])
            slope, icpt = np.polyfit(x, y, 1)
            res = y - (slope * x + icpt)
            thr = sheet.smps.esr_ohm * (FAILURE["esr"] - 1.0)
            print(f"  bus0 (ESR proxy, {len(pts)} flights): slope {slope:+.3f} V/A per ohm of "
                  f"ESR, residual sd {np.std(res, ddof=2):.4f} V/A = "
                  f"{np.std(res, ddof=2) / max(abs(slope), 1e-12) / thr:.2f} ESR failure "
                  f"thresholds ({thr:g} ohm; the slope fitted on these flights); stated sd mean "
                  f"{np.mean([p[1].sd for p in pts]):.4f} V/A")


if __name__ == "__main__":
    main()
