"""``mapr fleet-archive``: write a synthetic fleet archive for ``mapr fleet`` (docs/fleet.md).

::

    mapr fleet-archive archive/ --tails 20 --flights 10          # 200 recordings
    mapr fleet archive/ --dictionary dictionary.npz --catalog fleet.db

Each tail is the testbed aircraft (one EMA, the shipped ICD), each flight ``--flight-s``
seconds of its bus traffic with a BIT at the start of every ``--bit-every``-th flight, as
``ARCHIVE/TAIL/flight-NNNN.ch10``; a share of the tails (``--degrading``) has an actuator that
ages along a degradation trajectory (kinds drawn from ``--kinds``), the others stay healthy.
``ARCHIVE/fleet.json`` declares each recording's flight hours and holds the truth (kind, true
value per flight, end of life). The same ``--seed`` writes the same archive, byte for byte.
The bus traffic is flown once and each flight's EMA answers are recomputed for its health
(:mod:`mapr_daemon.testbed.flight_template`); tails are written by ``--jobs`` processes. The
time taken is printed at the end.

Exit codes: 0 written; 2 a bad argument or a folder that is not empty; 78 an unknown aging
kind or flight condition.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.validate import bounded_int
from mapr_daemon.errors import ConfigError


def add_subparser(subparsers: Any) -> None:
    p = subparsers.add_parser("fleet-archive",
                              help="write a synthetic fleet archive of Chapter 10 recordings",
                              description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("archive", type=Path, help="folder to write (created)")
    p.add_argument("--tails", type=bounded_int(1, 899, "--tails"), default=3,
                   help="tails, N101 onwards (default 3)")
    p.add_argument("--flights", type=bounded_int(1, 9999, "--flights"), default=3,
                   help="flights per tail (default 3)")
    p.add_argument("--seed", type=int, default=1, help="seed (default 1)")
    p.add_argument("--degrading", type=float, default=0.5, metavar="SHARE",
                   help="share of tails whose actuator ages (default 0.5)")
    p.add_argument("--kinds", default="esr,friction",
                   help="aging kinds drawn for them, comma-separated (default esr,friction)")
    p.add_argument("--life-flights", type=float, default=0.0, metavar="N",
                   help="mean life of an aging actuator in flights (default 1.5 x --flights)")
    p.add_argument("--bit-every", type=bounded_int(1, 9999, "--bit-every"), default=1,
                   metavar="N", help="a BIT on every N-th flight (default 1)")
    p.add_argument("--flight-s", type=float, default=2.0, metavar="S",
                   help="seconds of bus traffic per recording (default 2)")
    p.add_argument("--flight-hours", type=float, default=1.5, metavar="H",
                   help="flight hours each recording stands for, in fleet.json (default 1.5)")
    p.add_argument("--condition", default="cruise",
                   help="flight condition: ground, approach, climb, cruise, dash")
    p.add_argument("--jobs", type=bounded_int(1, 256, "--jobs"), default=None, metavar="N",
                   help="processes writing tails (default: one per core)")
    p.set_defaults(func=run, validate=validate)


def validate(args: argparse.Namespace) -> str | None:
    """Values argparse's types cannot check alone, as one line (exit 2)."""
    if not 0.0 <= args.degrading <= 1.0:
        return f"--degrading is a share 0-1, not {args.degrading:g}"
    if not 0.0 < args.flight_s <= 3600.0:
        return f"--flight-s must be above 0 and at most 3600, not {args.flight_s:g}"
    if not args.flight_hours > 0.0 or not args.life_flights >= 0.0:
        return "--flight-hours must be above 0 and --life-flights 0 or more"
    if args.archive.exists() and any(args.archive.iterdir()):
        return f"{args.archive} is not empty (an archive is written into a new folder)"
    return None


def run(args: argparse.Namespace) -> int:
    from concurrent.futures import ProcessPoolExecutor

    from mapr_daemon.ema.degradation import FAILURE
    from mapr_daemon.ema.profile import condition
    from mapr_daemon.testbed.fleet import FleetSpec, generate

    kinds = tuple(k.strip() for k in args.kinds.split(",") if k.strip())
    unknown = [k for k in kinds if k not in FAILURE]
    if unknown or not kinds:
        raise ConfigError(f"no aging model for {', '.join(map(repr, unknown)) or 'none'} "
                          f"(known: {', '.join(FAILURE)})", field="--kinds")
    condition(args.condition)   # an unknown one: ConfigError, exit 78, before any work
    spec = FleetSpec(tails=args.tails, flights=args.flights, seed=args.seed,
                     degrading=args.degrading, kinds=kinds, life_flights=args.life_flights,
                     bit_every=args.bit_every, flight_s=args.flight_s,
                     flight_hours=args.flight_hours, condition=args.condition)
    jobs = min(args.jobs or os.cpu_count() or 1, spec.tails)
    started = time.monotonic()
    if jobs > 1:
        with ProcessPoolExecutor(jobs) as pool:
            manifest = generate(args.archive, spec, pool.map)
    else:
        manifest = generate(args.archive, spec)
    wall = time.monotonic() - started
    recordings = manifest["recordings"]
    aging = sorted(tail for tail, truth in manifest["truth"].items() if truth)
    print(f"fleet-archive: {len(recordings)} recordings ({spec.tails} tails x {spec.flights} "
          f"flights of {spec.flight_s:g} s, {sum(r['bit'] for r in recordings)} with a BIT) "
          f"in {args.archive}, written in {wall:.1f} s by {jobs} process(es) "
          f"({wall / len(recordings):.3f} s per recording)\n"
          f"aging: {', '.join(aging) or 'none'}; truth and flight hours in "
          f"{args.archive / 'fleet.json'}", file=sys.stdout)
    return exitcodes.OK
