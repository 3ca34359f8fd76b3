"""Two EMAs of different types on one loopback bus, each diagnosed with its own dictionary.

The aileron (RT 5, 2 kHz) and the elevator (RT 7, 1 kHz) of
``configs/icd/ema-testbed-two-ema.yaml`` fly one BIT each per flight, each with its own seeded
fault or none; the bus records are decoded once and each BIT is cut out with its asset's
wiring and decided by a dictionary built for that actuator at its bus rate. Prints one line
per flight and EMA (seeded fault, decision, score vs threshold) and the counts of right
calls. Dictionaries: small envelope ones (healthy, ESR, friction, phase-A high-side short and
open; the daemon tests' spec), seeds from 0; flights on fresh seeds, printed.

    python3 bench/two_ema.py [--seed N] [--flights-per-case 1]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.seeds import fresh
from drivers.backends.loopback import LoopbackMonitor
from mapr_daemon.ema.faults import FaultSet, parse_fault
from mapr_daemon.ema.params import ActuatorParams, load_actuator, with_sample_rate
from mapr_daemon.icd import SignalStream, load_icd
from mapr_daemon.pipeline import wiring
from mapr_daemon.pipeline.bitwatch import BitWatch
from mapr_daemon.reasoner.diagnosis.dictionary import DictionarySpec
from mapr_daemon.reasoner.reasoner import Reasoner
from mapr_daemon.reasoner.training import dictionary_build
from mapr_daemon.testbed.aircraft import Aircraft
from mapr_daemon.testbed.profiles import steady_profile

ROOT = Path(__file__).resolve().parents[1]
ICD = ROOT / "configs" / "icd" / "ema-testbed-two-ema.yaml"
FRAMES = 1020
CASES: list[tuple[str | None, str | None]] = [
    (None, None), (None, "esr=0.6"), ("friction@0.8", None), ("open=A_high", "esr@0.5"),
    ("esr=0.6", "open=A_high"), (None, "friction@0.8")]
"""(aileron fault, elevator fault) per flight."""
SPEC = DictionarySpec(pressures_pa=(0.0, 1600.0), nominal_per_pressure=4,
                      severities=(0.25, 0.5, 0.75, 1.0), kinds=("esr", "friction"),
                      shorts=("A_high",), opens=("A_high",), healthy_runs=120,
                      calibration_runs=20, envelope=True, ground_share=0.2,
                      threshold_margin=1.5)


def faults(text: str | None, params: ActuatorParams) -> FaultSet:
    return FaultSet() if text is None else FaultSet.of([parse_fault(text, params)])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seed", type=int)
    parser.add_argument("--flights-per-case", type=int, default=1)
    args = parser.parse_args()
    seed = fresh(args.seed)
    icd = load_icd(ICD)
    aileron = with_sample_rate(load_actuator(ROOT / "configs/actuators/aileron-uav.yaml"), 2000)
    elevator = with_sample_rate(load_actuator(ROOT / "configs/actuators/elevator-uav.yaml"), 1000)
    started = time.monotonic()
    dictionaries = [dictionary_build.build(aileron, SPEC), dictionary_build.build(elevator, SPEC)]
    print(f"dictionaries built in {time.monotonic() - started:.0f} s (aileron 2 kHz, "
          f"elevator 1 kHz)")
    right = {"EMA1": 0, "EMA2": 0}
    healthy_worst = {"EMA1": 0.0, "EMA2": 0.0}   # highest score/threshold of a healthy BIT
    faulty_worst = {"EMA1": float("inf"), "EMA2": float("inf")}   # lowest of a faulted one
    total = 0
    for repeat in range(args.flights_per_case):
        for case, (fault1, fault2) in enumerate(CASES):
            s = seed + 1000 * repeat + 10 * case
            aircraft = Aircraft(icd, steady_profile(2000.0, "cruise"), aileron,
                                faults(fault1, aileron), seed=s, bit_requests_s=(0.0,))
            aircraft.add_ema(7, elevator, faults(fault2, elevator), seed=s + 1,
                             bit_requests_s=(0.0,))
            with LoopbackMonitor(terminals=aircraft.terminals(), schedule=aircraft.schedule(),
                                 frames=FRAMES, seed=s, bit_level=False) as monitor:
                series = SignalStream(icd).feed(list(monitor))
            total += 1
            for name, fault, params, d, signals in (
                    ("EMA1", fault1, aileron, dictionaries[0], wiring.DEFAULT_SIGNALS),
                    ("EMA2", fault2, elevator, dictionaries[1],
                     wiring.TWO_EMA_ELEVATOR_SIGNALS)):
                found = BitWatch(Reasoner(d, params), signals=signals).feed(series)
                if len(found) != 1:
                    print(f"flight seed {s} {name}: {len(found)} BITs found (expected 1)")
                    continue
                event = found[0].decision
                said = event.fault if event.anomaly else None
                truth = None if fault is None else fault.split("=")[0].split("@")[0]
                ok = said == truth
                right[name] += ok
                ev = event.evidence
                ratio = ev.get("score", 0.0) / max(ev.get("threshold", 1.0), 1e-9)
                if fault is None:
                    healthy_worst[name] = max(healthy_worst[name], ratio)
                else:
                    faulty_worst[name] = min(faulty_worst[name], ratio)
                print(f"flight seed {s} {name}: seeded {fault or 'healthy':<14} -> "
                      f"{said or 'nominal':<10} score {ev.get('score', 0.0):8.0f} vs "
                      f"threshold {ev.get('threshold', 0.0):4.0f}  {'ok' if ok else 'WRONG'}")
    print(f"right calls: EMA1 (aileron) {right['EMA1']}/{total}, "
          f"EMA2 (elevator) {right['EMA2']}/{total}")
    for name in right:
        print(f"{name} worst cases: healthy score/threshold max {healthy_worst[name]:.3f}, "
              f"faulted score/threshold min {faulty_worst[name]:.1f}")


if __name__ == "__main__":
    main()
