"""``mapr demo``: the main job on the simulated aircraft, end to end (a simulator front end:
it lives in the testbed, and ``mapr`` registers it by module path).

A JSBSim flight (the c172x, trimmed at a flight condition, with bank manoeuvres) drives the
flight control computer, which commands the aileron EMA over the loopback 1553 bus and asks
it for a built-in test at once; the EMA plant answers with a seeded fault and runs its BIT
motion; the air-data computer reports the flight's air data. The bus runs at the bit level —
every word Manchester-encoded, sampled as a logic analyzer would, decoded and assembled back —
with two bus errors injected on the way. MAPR prints the traffic with engineering values
decoded through the message table and what it caught; then, as the daemon does, it cuts the
BIT out of the traffic, the reasoner decides (anomaly, fault, severity, state of health) and
the event goes into a fault catalog that ``mapr catalog list`` reads.

The reasoner needs a fault dictionary: ``--dictionary FILE`` (from ``mapr dictionary build``),
or by default one built from the shipped spec on first use and cached (a minute or two).

    mapr demo                                  # the default fault, cruise, 2 s
    mapr demo --fault esr=0.6 --fault friction@0.5 --seconds 4 --condition approach
    mapr demo --fault none --word-level
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from drivers.mil1553.record import MonitorRecord
from mapr_daemon.catalog import CatalogWriter
from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.render import record_line
from mapr_daemon.daemon.config import DEFAULT_ICD
from mapr_daemon.ema.bit import bit_profile
from mapr_daemon.ema.faults import FaultSet, parse_fault
from mapr_daemon.ema.params import (
    ActuatorParams,
    default_actuator_path,
    load_actuator,
    with_sample_rate,
)
from mapr_daemon.ema.profile import CONDITIONS
from mapr_daemon.icd import Icd, Series, collect, format_values, load_icd

if TYPE_CHECKING:
    from drivers.backends.loopback import Injection

DEFAULT_FAULT = "esr@0.6"


def injected() -> tuple[Injection, ...]:
    """Two bus errors the demo injects: a parity error in an EMA feedback word, and the
    air-data computer failing to answer once (the bus controller retries on bus B)."""
    from drivers.backends.loopback import Injection
    return (Injection("parity", rt=5, sa=4, skip=40),
            Injection("no_response", rt=6, sa=1, skip=20))


def bit_needs_s(params: ActuatorParams) -> float:
    """Flight time a whole BIT needs: the first request slot (12 ms), the actuator's BIT
    motion, a few samples."""
    motion = bit_profile(params.sensors.sample_rate_hz, "ground", params.bit)
    return 0.012 + float(motion.time_s[-1]) + 0.005


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
    parser.add_argument("--dictionary", metavar="FILE",
                        help="fault dictionary (default: built once from the shipped spec and "
                             "cached)")
    parser.add_argument("--catalog", metavar="PATH",
                        help="fault catalog to write the BIT's event to (default: "
                             "demo-catalog.sqlite in the cache directory)")
    parser.add_argument("--no-diagnose", action="store_true",
                        help="only the bus: no BIT, no reasoner, no catalog")
    parser.set_defaults(func=run)


def seeded_faults(texts: list[str] | None) -> FaultSet:
    params = load_actuator(default_actuator_path())
    chosen = texts if texts is not None else [DEFAULT_FAULT]
    if chosen == ["none"]:
        return FaultSet()
    return FaultSet.of(parse_fault(text, params) for text in chosen)


def run(args: argparse.Namespace) -> int:
    # The loopback bus loads numba kernels, JSBSim is slow to load: imported when the demo
    # runs, not for `mapr demo --help`.
    from drivers.backends.loopback import LoopbackMonitor
    from mapr_daemon.testbed.aircraft import Aircraft
    from mapr_daemon.testbed.profiles_jsbsim import jsbsim_flight

    if args.dictionary and not args.no_diagnose and not Path(args.dictionary).is_file():
        print(f"mapr demo: {args.dictionary}: no such dictionary", file=sys.stderr)
        return exitcodes.USAGE
    icd = load_icd(args.icd)
    faults = seeded_faults(args.fault)
    params = with_sample_rate(load_actuator(default_actuator_path()), 2000.0)
    flight = jsbsim_flight(2000.0, args.condition, duration_s=args.seconds, seed=args.seed)
    aircraft = Aircraft(icd, flight, params, faults, seed=args.seed,
                        bit_requests_s=() if args.no_diagnose else (0.0,))
    level = "word level" if args.word_level else "bit level, 16 MS/s"
    print(f"MAPR demo: JSBSim c172x, {args.condition}, {args.seconds:g} s; aileron EMA with "
          f"{faults.label()}; loopback 1553 bus at {level}; "
          f"injected: {', '.join(i.kind for i in injected())}")
    print()
    frames = round(args.seconds * 1e9 / aircraft.schedule().frame_ns)
    records: list[MonitorRecord] = []
    started = time.monotonic()
    with LoopbackMonitor(terminals=aircraft.terminals(), schedule=aircraft.schedule(),
                         frames=frames, injections=injected(), bit_level=not args.word_level,
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
    if args.no_diagnose:
        return exitcodes.OK
    return diagnose(args, icd, records, params)


def diagnose(args: argparse.Namespace, icd: Icd, records: list[MonitorRecord],
             params: ActuatorParams) -> int:
    """The daemon's path on the demo's traffic: BIT -> reasoner -> catalog."""
    from mapr_daemon.cli.demo_reasoner import (
        cache_dir,
        cached_dictionary,
        describe,
        diagnose_bits,
    )

    print()
    needs = bit_needs_s(params)
    if args.seconds < needs:
        print(f"No complete BIT in {args.seconds:g} s of flight (the BIT is requested at once "
              f"and needs {needs:.2f} s): nothing to diagnose; fly --seconds 2 or more.")
        return exitcodes.OK
    dictionary = Path(args.dictionary) if args.dictionary else \
        cached_dictionary(params, default_actuator_path())
    batch = diagnose_bits(args.icd, records, dictionary)
    if not batch.bits:
        print("The BIT was not found complete on the bus (see the log): nothing to diagnose.")
        return exitcodes.OK
    for bit in batch.bits:
        for line in describe(bit.decision):
            print(line)
    catalog = Path(args.catalog) if args.catalog else cache_dir() / "demo-catalog.sqlite"
    catalog.parent.mkdir(parents=True, exist_ok=True)
    with CatalogWriter(catalog) as writer:
        writer.open_session(backend="loopback (mapr demo)", config_hash="demo")
        ids = writer.add_events(batch.events)
    written = f"event {', '.join(map(str, ids))} written" if ids else "no event written"
    print(f"Fault catalog {catalog}: {written}; read it with "
          f"`mapr catalog list --catalog {catalog}`")
    return exitcodes.OK


def summarize(records: list[MonitorRecord], series: dict[str, Series], elapsed: float,
              seconds: float) -> None:
    caught = Counter(e for r in records for e in r.errors)
    wanted = {"parity", "no_response"}
    print()
    print(f"{len(records)} messages in {elapsed:.1f} s for {seconds:g} s of flight; errors "
          f"caught: {dict(caught) or 'none'}; both injected errors named: "
          f"{wanted <= set(caught)}")
    followed = "command_echo" if "command_echo" in series else "position_command"
    if "surface_position" in series and followed in series:
        # the command the EMA reports following: the FCC's, or its own BIT motion
        pos, cmd = series["surface_position"], series[followed]
        command = np.interp(pos.t_ns, cmd.t_ns, cmd.value)
        error = pos.value - command
        current = series["phase_current_a"].value
        print(f"EMA over the bus: surface {pos.value.min():+.2f}..{pos.value.max():+.2f} deg, "
              f"tracking error rms {np.sqrt(np.mean(error ** 2)):.3f} deg, phase A current "
              f"rms {np.sqrt(np.mean(current ** 2)):.3f} A, DC bus "
              f"{np.median(series['dc_bus_voltage'].value):.2f} V")

