"""``mapr demo``: the main job on the simulated aircraft, end to end.

A JSBSim flight (the c172x, trimmed at a flight condition, with bank manoeuvres) drives the
flight control computer, which commands the aileron EMA over the loopback 1553 bus; the EMA
plant answers with a seeded fault; the air-data computer reports the flight's air data. The
bus runs at the bit level — every word Manchester-encoded, sampled as a logic analyzer would,
decoded and assembled back — with two bus errors injected on the way. MAPR prints the traffic
with engineering values decoded through the message table, then what it caught and what the
actuator's signals show.

    mapr demo                                  # inverter phase-A Ron at 5x, cruise, 2 s
    mapr demo --fault esr=0.6 --fault friction@0.5 --seconds 4 --condition approach
    mapr demo --fault none --word-level
"""

from __future__ import annotations

import argparse
import time
from collections import Counter
from typing import Any

import numpy as np

from drivers.backends.loopback import Injection, LoopbackMonitor
from drivers.mil1553.record import MonitorRecord
from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.render import record_line
from mapr_daemon.ema.faults import FaultSet, parse_fault
from mapr_daemon.ema.params import default_actuator_path, load_actuator, with_sample_rate
from mapr_daemon.icd import Series, collect, format_values, load_icd
from mapr_daemon.testbed.aircraft import Aircraft
from mapr_daemon.testbed.profiles import CONDITIONS
from mapr_daemon.testbed.profiles_jsbsim import jsbsim_flight

DEFAULT_ICD = "configs/icd/ema-testbed.yaml"
DEFAULT_FAULT = "inverter_ron_a_high=0.18"
INJECTED = (Injection("parity", rt=5, sa=4, skip=40),
            Injection("no_response", rt=6, sa=1, skip=20))
"""Two bus errors the demo injects: a parity error in an EMA feedback word, and the air-data
computer failing to answer once (the bus controller retries on bus B)."""


def add_subparser(subparsers: Any) -> None:
    parser = subparsers.add_parser("demo", help="fly the simulated aircraft and monitor its bus",
                                   description=__doc__,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--fault", action="append", metavar="KIND=VALUE",
                        help=f"EMA fault to seed (repeatable; 'none' for a healthy EMA; "
                             f"default {DEFAULT_FAULT})")
    parser.add_argument("--seconds", type=float, default=2.0, help="flight time (default 2)")
    parser.add_argument("--condition", default="cruise", choices=sorted(CONDITIONS))
    parser.add_argument("--icd", default=DEFAULT_ICD, help="message table")
    parser.add_argument("--word-level", action="store_true",
                        help="skip the Manchester waveform (faster)")
    parser.add_argument("--show", type=int, default=14, help="messages to print in full")
    parser.add_argument("--seed", type=int, default=1)
    parser.set_defaults(func=run)


def seeded_faults(texts: list[str] | None) -> FaultSet:
    params = load_actuator(default_actuator_path())
    chosen = texts if texts is not None else [DEFAULT_FAULT]
    if chosen == ["none"]:
        return FaultSet()
    return FaultSet.of(parse_fault(text, params) for text in chosen)


def run(args: argparse.Namespace) -> int:
    icd = load_icd(args.icd)
    faults = seeded_faults(args.fault)
    params = with_sample_rate(load_actuator(default_actuator_path()), 2000.0)
    flight = jsbsim_flight(2000.0, args.condition, duration_s=args.seconds, seed=args.seed)
    aircraft = Aircraft(icd, flight, params, faults, seed=args.seed)
    level = "word level" if args.word_level else "bit level, 16 MS/s"
    print(f"MAPR demo: JSBSim c172x, {args.condition}, {args.seconds:g} s; aileron EMA with "
          f"{faults.label()}; loopback 1553 bus at {level}; "
          f"injected: {', '.join(i.kind for i in INJECTED)}")
    print()
    frames = round(args.seconds * 1e9 / aircraft.schedule().frame_ns)
    records: list[MonitorRecord] = []
    started = time.monotonic()
    with LoopbackMonitor(terminals=aircraft.terminals(), schedule=aircraft.schedule(),
                         frames=frames, injections=INJECTED, bit_level=not args.word_level,
                         seed=args.seed) as monitor:
        shown = 0
        for record in monitor:
            records.append(record)
            if shown < args.show or record.errors:
                values = format_values(icd, record) if record.data else ""
                print(record_line(record, values))
                shown += 1
            elif shown == args.show:
                print("    ... (only messages with errors from here on)")
                shown += 1
        elapsed = time.monotonic() - started
        print()
        print(monitor.stats.table())
    summarize(records, collect(icd, records)[0], elapsed, args.seconds)
    return exitcodes.OK


def summarize(records: list[MonitorRecord], series: dict[str, Series], elapsed: float,
              seconds: float) -> None:
    caught = Counter(e for r in records for e in r.errors)
    wanted = {"parity", "no_response"}
    print()
    print(f"{len(records)} messages in {elapsed:.1f} s for {seconds:g} s of flight; errors "
          f"caught: {dict(caught) or 'none'}; both injected errors named: "
          f"{wanted <= set(caught)}")
    if "surface_position" in series and "position_command" in series:
        pos, cmd = series["surface_position"], series["position_command"]
        command = np.interp(pos.t_ns, cmd.t_ns, cmd.value)
        error = pos.value - command
        current = series["phase_current_a"].value
        print(f"EMA over the bus: surface {pos.value.min():+.2f}..{pos.value.max():+.2f} deg, "
              f"tracking error rms {np.sqrt(np.mean(error ** 2)):.3f} deg, phase A current "
              f"rms {np.sqrt(np.mean(current ** 2)):.3f} A, DC bus "
              f"{np.median(series['dc_bus_voltage'].value):.2f} V")

