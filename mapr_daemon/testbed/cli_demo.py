"""``mapr demo``: the main job on the simulated aircraft, end to end (a simulator front end:
it lives in the testbed, and ``mapr`` registers it by module path).

A JSBSim flight (the c172x, trimmed at a flight condition, with bank manoeuvres) drives the
flight control computer, which commands two EMAs of different types over one loopback 1553
bus — the aileron (RT 5, 2 kHz sample blocks) and the elevator (RT 7, 1 kHz) of
``configs/icd/ema-testbed-two-ema.yaml`` — and asks each for a built-in test at once; the
EMA plants answer, one of them with a seeded fault, and run their BIT motions; the air-data
computer reports the flight's air data. The bus runs at the bit level — every word
Manchester-encoded, sampled as a logic analyzer would, decoded and assembled back — with two
bus errors injected on the way. MAPR prints the traffic with engineering values decoded
through the message table and what it caught; then the daemon's pipeline, configured with
both actuators, cuts each BIT out of the traffic, the reasoner decides (anomaly, fault,
severity), each actuator's trend gives its health (SoH, leading mode, RUL or why none) and
the BITs go into a fault catalog that ``mapr catalog list`` and ``mapr health`` read.

Each actuator type needs a fault dictionary and a prognostic model: ``--dictionary FILE``
(``--prognosis FILE``) for the aileron, ``--elevator-dictionary`` (``--elevator-prognosis``)
for the elevator (from ``mapr dictionary build --prognosis``). By default both come pre-built
with the package (from the demo's smaller spec, ``configs/reasoner/dictionary-demo.yaml``;
:mod:`mapr_daemon.testbed.demo_models`), or, when the code has changed since they were built,
are built once and cached (minutes of CPU, with a progress line). A dictionary given without
its prognostic model is diagnosed without a trend. Each run is the aircraft's next flight in
the catalog. With a table that has no RT 7
(``--icd configs/icd/ema-testbed.yaml``) the aileron flies alone.

    mapr demo                                  # the default fault on the aileron, cruise, 2 s
    mapr demo --faulted elevator --fault friction@0.8
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
from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.traffic.render import record_line
from mapr_daemon.ema.bit import bit_profile
from mapr_daemon.ema.faults import FaultSet, parse_fault
from mapr_daemon.ema.params import (
    ActuatorParams,
    default_actuator_path,
    load_actuator,
    with_sample_rate,
)
from mapr_daemon.ema.profile import CONDITIONS
from mapr_daemon.icd import Series, collect, format_values, load_icd
from mapr_daemon.pipeline.settings import DEFAULT_ICD
from mapr_daemon.pipeline.wiring import DEFAULT_SIGNALS, TWO_EMA_ELEVATOR_SIGNALS

if TYPE_CHECKING:
    from drivers.backends.loopback import Injection
    from mapr_daemon.testbed.demo_health import DemoAsset

DEFAULT_FAULT = "esr@0.6"
TWO_EMA_ICD = DEFAULT_ICD.with_name("ema-testbed-two-ema.yaml")


class Ema:
    """One EMA the demo flies: its catalog name, surface, RT, data sheet (at its bus rate),
    wiring, and the files its diagnosis may be given."""

    def __init__(self, name: str, surface: str, rt: int, actuator: Path, rate_hz: float,
                 signals: dict[str, str], dictionary: str | None, prognosis: str | None
                 ) -> None:
        self.name, self.surface, self.rt, self.actuator = name, surface, rt, actuator
        self.params = with_sample_rate(load_actuator(actuator), rate_hz)
        self.signals = signals
        self.dictionary = None if dictionary is None else Path(dictionary)
        self.prognosis = None if prognosis is None else Path(prognosis)

    def asset(self) -> DemoAsset:
        """Its daemon asset: the files given, else the demo's (pre-built, cached, or built)."""
        from mapr_daemon.testbed.demo_health import DemoAsset
        from mapr_daemon.testbed.demo_reasoner import cached_models
        dictionary, prognosis = self.dictionary, self.prognosis
        if dictionary is None:
            dictionary, cached = cached_models(self.params, self.actuator)
            prognosis = prognosis or cached
        return DemoAsset(self.name, self.rt, self.actuator, self.signals, dictionary, prognosis)


def emas(args: argparse.Namespace) -> list[Ema]:
    """The aileron (RT 5, 2 kHz) and the elevator (RT 7, 1 kHz)."""
    aileron = default_actuator_path()
    return [Ema("EMA1", "aileron", 5, aileron, 2000.0, dict(DEFAULT_SIGNALS), args.dictionary,
                args.prognosis),
            Ema("EMA2", "elevator", 7, aileron.with_name("elevator-uav.yaml"), 1000.0,
                dict(TWO_EMA_ELEVATOR_SIGNALS), args.elevator_dictionary,
                args.elevator_prognosis)]


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
                        help=f"EMA fault to seed on the --faulted EMA (repeatable; 'none' for "
                             f"healthy EMAs; default {DEFAULT_FAULT})")
    parser.add_argument("--faulted", choices=("aileron", "elevator"), default="aileron",
                        help="the EMA that carries the seeded fault; the other flies healthy "
                             "(default aileron)")
    parser.add_argument("--seconds", type=float, default=2.0, help="flight time (default 2)")
    parser.add_argument("--condition", default="cruise", choices=sorted(CONDITIONS))
    parser.add_argument("--icd", default=str(TWO_EMA_ICD),
                        help="message table (default: the two-EMA testbed's; a table without "
                             "RT 7 flies the aileron alone)")
    parser.add_argument("--word-level", action="store_true",
                        help="skip the Manchester waveform (faster)")
    parser.add_argument("--show", type=int, default=14, help="messages to print in full")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--dictionary", metavar="FILE",
                        help="the aileron's fault dictionary (default: the pre-built demo "
                             "dictionary, else built once from the demo spec and cached)")
    parser.add_argument("--prognosis", metavar="FILE",
                        help="the aileron's prognostic model (default: the demo's, with its "
                             "dictionary; none with --dictionary)")
    parser.add_argument("--elevator-dictionary", metavar="FILE",
                        help="the elevator's fault dictionary, at 1 kHz (default: the demo's)")
    parser.add_argument("--elevator-prognosis", metavar="FILE",
                        help="the elevator's prognostic model (as --prognosis)")
    parser.add_argument("--catalog", metavar="PATH",
                        help="fault catalog to write the BITs to (default: "
                             "demo-catalog.sqlite in the cache directory)")
    parser.add_argument("--no-diagnose", action="store_true",
                        help="only the bus: no BIT, no reasoner, no catalog")
    parser.set_defaults(func=run)


def seeded_faults(texts: list[str] | None, params: ActuatorParams | None = None) -> FaultSet:
    params = params or load_actuator(default_actuator_path())
    chosen = texts if texts is not None else [DEFAULT_FAULT]
    if chosen == ["none"]:
        return FaultSet()
    return FaultSet.of(parse_fault(text, params) for text in chosen)


def missing_file(args: argparse.Namespace) -> str | None:
    """The first diagnosis file given that does not exist."""
    for option in ("dictionary", "prognosis", "elevator_dictionary", "elevator_prognosis"):
        value = getattr(args, option)
        if value and not Path(value).is_file():
            return f"{value}: no such {option.rsplit('_', 1)[-1].replace('prognosis', 'model')}"
    return None


def run(args: argparse.Namespace) -> int:
    # The loopback bus loads numba kernels, JSBSim is slow to load: imported when the demo
    # runs, not for `mapr demo --help`.
    from drivers.backends.loopback import LoopbackMonitor
    from mapr_daemon.testbed.aircraft import Aircraft
    from mapr_daemon.testbed.profiles_jsbsim import jsbsim_flight

    missing = None if args.no_diagnose else missing_file(args)
    if missing:
        print(f"mapr demo: {missing}", file=sys.stderr)
        return exitcodes.USAGE
    icd = load_icd(args.icd)
    flown = emas(args)
    faulted = next(e for e in flown if e.surface == args.faulted)
    faults = seeded_faults(args.fault, faulted.params)
    flight = jsbsim_flight(2000.0, args.condition, duration_s=args.seconds, seed=args.seed)
    requests = () if args.no_diagnose else (0.0,)
    first, *others = flown
    aircraft = Aircraft(icd, flight, first.params, faults if first is faulted else FaultSet(),
                        seed=args.seed, bit_requests_s=requests, rt=first.rt)
    for k, ema in enumerate(others, start=1):
        try:
            aircraft.add_ema(ema.rt, ema.params, faults if ema is faulted else FaultSet(),
                             seed=args.seed + k, bit_requests_s=requests)
        except KeyError:
            flown.remove(ema)   # the table has no such terminal: this EMA is not fitted
    if faulted not in flown:
        print(f"mapr demo: {icd.name} has no {faulted.surface} EMA (RT {faulted.rt}) to "
              f"seed the fault on", file=sys.stderr)
        return exitcodes.USAGE
    level = "word level" if args.word_level else "bit level, 16 MS/s"
    fitted = "; ".join(f"{e.surface} EMA ({e.name}, RT {e.rt}, "
                       f"{e.params.sensors.sample_rate_hz / 1000:g} kHz) "
                       f"{faults.label() if e is faulted else 'healthy'}" for e in flown)
    print(f"MAPR demo: JSBSim c172x, {args.condition}, {args.seconds:g} s; {fitted}; "
          f"loopback 1553 bus at {level}; injected: {', '.join(i.kind for i in injected())}")
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
    summarize(records, collect(icd, records)[0], elapsed, args.seconds, flown)
    if args.no_diagnose:
        return exitcodes.OK
    return diagnose(args, records, flown)


def diagnose(args: argparse.Namespace, records: list[MonitorRecord], flown: list[Ema]) -> int:
    """The daemon's path on the demo's traffic: BITs -> pipeline (one asset per EMA) ->
    catalog -> each actuator's diagnosis and health."""
    from drivers.errors import MaprError
    from mapr_daemon.errors import CatalogError
    from mapr_daemon.testbed.demo_health import demo_config, diagnose_into_catalog
    from mapr_daemon.testbed.demo_reasoner import cache_dir, describe
    from mapr_daemon.views.figures import health_summary
    from mapr_daemon.views.health import health_table

    print()
    needs = max(bit_needs_s(e.params) for e in flown)
    if args.seconds < needs:
        print(f"No complete BIT in {args.seconds:g} s of flight (the BIT is requested at once "
              f"and needs {needs:.2f} s): nothing to diagnose; fly --seconds 2 or more.")
        return exitcodes.OK
    catalog = Path(args.catalog) if args.catalog else cache_dir() / "demo-catalog.sqlite"
    try:
        config = demo_config(args.icd, [e.asset() for e in flown])
        done = diagnose_into_catalog(config, records, catalog)
    except MaprError as error:   # an unreadable dictionary or model; a catalog it cannot write
        print(f"mapr demo: {error}", file=sys.stderr)
        return exitcodes.NOINPUT if isinstance(error, CatalogError) else exitcodes.USAGE
    for e in flown:
        bits = done.bits_of(e.name)
        print(f"{e.name} ({e.surface} EMA, RT {e.rt}):")
        if not bits:
            print("  its BIT was not found complete on the bus (see the log): not diagnosed")
        for bit in bits:
            for line in describe(bit.decision):
                print(f"  {line}")
    for failure in done.batch.failures:
        print(f"{failure.asset}: the reasoner failed on a BIT: {failure.error}")
    rows = [done.health[e.name] for e in flown if e.name in done.health]
    if rows:
        print()
        for row in rows:
            print(f"{row.name}: {health_summary(row.health)}")
        print()
        print(health_table(rows))
    ids = done.event_ids
    written = f"event {', '.join(map(str, ids))} written" if ids else "no event written"
    print(f"Fault catalog {catalog}: {len(done.batch.outcomes)} BITs stored, {written}; read "
          f"it with `mapr health --catalog {catalog}` and `mapr catalog list --catalog "
          f"{catalog}`")
    return exitcodes.OK


def summarize(records: list[MonitorRecord], series: dict[str, Series], elapsed: float,
              seconds: float, flown: list[Ema]) -> None:
    caught = Counter(e for r in records for e in r.errors)
    wanted = {"parity", "no_response"}
    print()
    print(f"{len(records)} messages in {elapsed:.1f} s for {seconds:g} s of flight; errors "
          f"caught: {dict(caught) or 'none'}; both injected errors named: "
          f"{wanted <= set(caught)}")
    for e in flown:
        name = {v: k for k, v in e.signals.items()}
        pos_name, cur_name, bus_name = (name.get(c) for c in (
            "position_deg", "phase_a_current_a", "dc_bus_voltage_v"))
        prefix = pos_name[:-len("surface_position")] if pos_name else ""
        followed = next((f"{prefix}{n}" for n in ("command_echo", "position_command")
                         if f"{prefix}{n}" in series), None)
        if pos_name not in series or followed is None or cur_name not in series \
                or bus_name not in series:
            continue
        # the command the EMA reports following: the FCC's, or its own BIT motion
        pos, cmd = series[str(pos_name)], series[followed]
        command = np.interp(pos.t_ns, cmd.t_ns, cmd.value)
        error = pos.value - command
        current = series[str(cur_name)].value
        print(f"{e.surface.capitalize()} EMA over the bus: surface "
              f"{pos.value.min():+.2f}..{pos.value.max():+.2f} deg, tracking error rms "
              f"{np.sqrt(np.mean(error ** 2)):.3f} deg, phase A current rms "
              f"{np.sqrt(np.mean(current ** 2)):.3f} A, DC bus "
              f"{np.median(series[str(bus_name)].value):.2f} V")
