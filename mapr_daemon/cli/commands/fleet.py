"""``mapr fleet``: a fleet's Chapter 10 archive through the reasoner on Dask, into one catalog.

::

    mapr fleet ARCHIVE --dictionary dictionary.npz --catalog fleet.db       # local cluster
    mapr fleet ARCHIVE --config fleet.yaml --workers 2
    mapr fleet ARCHIVE --config fleet.yaml --scheduler tcp://10.0.0.5:8786  # existing cluster
    mapr fleet N101/flight-0001.ch10 N101/flight-0002.ch10 --dictionary d.npz
    mapr fleet ARCHIVE --dictionary d.npz --c10-channel 3   # only 1553 channel 3 of each file

Every recording (``*.ch10``/``*.c10`` under the folders given, or the files given) is one
Dask task that runs the daemon's records -> events path on it (as ``mapr replay
--diagnose``), reading every 1553 channel of it or only those given with ``--c10-channel``
(repeat it for more); the client alone writes the catalog, one transaction per recording, each
tail's flights in flight order, each tail's actuators trended on the client from that
tail's history (SoH and RUL need a prognostic model: ``--prognosis`` or the config's
``assets[].prognosis``). Tail and flight come from the path (``--pattern``, default
``TAIL/...NNNN.ch10``, searched below the archive folder given: a recording at its root is
reported, not named after the folder), the tail from a TMATS attribute first with
``--tail-tmats``; flight hours from the archive's ``fleet.json`` when it declares them, else
the recorded time. Every path a worker opens is made absolute here, and the configuration is
known by its files' content. Without ``--scheduler`` a local cluster starts (one
single-threaded worker process per core, or ``--workers N``), its dashboard address printed
on stderr when bokeh is installed (``mapr[dashboard]``). A recording already stored is
skipped, so a run stopped anywhere is resumed by running it again. Progress on stderr (a bar
on a terminal, plain lines otherwise), a summary on stdout. ``mapr fleet-archive`` writes a
synthetic archive.

Exit codes: 0 every recording stored; 65 some could not be processed (each named on stderr,
the rest stored; a recording without an asked ``--c10-channel`` is one of them, its line says
what it holds); 66 the catalog cannot be opened; 69 the scheduler cannot be reached within
``--connect-timeout`` or was lost mid-run (one line; the session closed, what was stored
kept); 78 a config, ICD or dictionary error; 2 a malformed argument (``--scheduler``).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.traffic.source import add_c10_channel_argument
from mapr_daemon.errors import CatalogError, ClusterError, ConfigError


def add_subparser(subparsers: Any) -> None:
    p = subparsers.add_parser("fleet", help="run a fleet's Chapter 10 archive through the "
                                            "reasoner on Dask, into one catalog",
                              description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("archive", nargs="+", help="archive folder(s) or Chapter 10 files")
    p.add_argument("--config", metavar="FILE", help="fleet config: default: and tails: "
                                                    "(docs/fleet.md)")
    p.add_argument("--dictionary", metavar="FILE", help="fault dictionary for every tail "
                                                        "(overrides the config's)")
    p.add_argument("--prognosis", metavar="FILE",
                   help="prognostic model for every actuator of every tail (overrides the "
                        "config's assets[].prognosis): SoH and RUL trends")
    p.add_argument("--icd", metavar="FILE", help="message table for every tail (overrides)")
    p.add_argument("--threshold", type=float, help="anomaly threshold override")
    p.add_argument("--catalog", metavar="PATH", help="fleet catalog (default: the default "
                                                     "config's)")
    p.add_argument("--pattern", metavar="REGEX", help="tail and flight from the path: a regex "
                                                      "with groups (?P<tail>) and (?P<flight>)")
    p.add_argument("--tail-tmats", metavar="CODE",
                   help="take the tail from this TMATS attribute when the file has it "
                        "(e.g. 'G\\TA', where 'mapr record --tail' writes it); the path "
                        "otherwise")
    add_c10_channel_argument(p, "read only this 1553 channel ID of every recording (repeat for "
                                "more; default: every channel)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--workers", type=int, metavar="N",
                       help="local cluster workers (default: one per core)")
    where.add_argument("--scheduler", metavar="ADDRESS",
                       help="an existing dask.distributed scheduler (tcp://host:8786)")
    p.add_argument("--connect-timeout", type=float, default=5.0, metavar="SECONDS",
                   help="give up on a scheduler not reached (or lost) within this long "
                        "(default 5)")
    bar = p.add_mutually_exclusive_group()
    bar.add_argument("--progress", action="store_true", default=None,
                     help="the progress bar even when stderr is not a terminal")
    bar.add_argument("--no-progress", action="store_false", dest="progress")
    p.set_defaults(func=run, validate=validate)


def _configs(args: argparse.Namespace) -> Any:
    from mapr_daemon.fleet.config import FleetConfig, load_fleet_config
    from mapr_daemon.service.config import Config, load_config

    fleet = load_fleet_config(args.config) if args.config else FleetConfig(load_config(None))

    def adjust(config: Config) -> Config:
        reasoner = config.reasoner
        if args.dictionary:
            reasoner = dataclasses.replace(reasoner, dictionary=args.dictionary)
        if args.threshold is not None:
            reasoner = dataclasses.replace(reasoner, threshold=args.threshold)
        if reasoner.dictionary is None:
            raise ConfigError("fleet analysis needs a fault dictionary: --dictionary FILE "
                              "(or reasoner.dictionary in --config)", path=config.source)
        assets = config.assets if not args.prognosis else tuple(
            dataclasses.replace(a, prognosis=args.prognosis) for a in config.assets)
        return dataclasses.replace(config, icd=args.icd or config.icd, reasoner=reasoner,
                                   assets=assets)

    return FleetConfig(adjust(fleet.default),
                       {tail: adjust(c) for tail, c in fleet.tails.items()})


def validate(args: argparse.Namespace) -> str | None:
    """A malformed ``--scheduler``, ``--workers`` or ``--connect-timeout`` as one line (exit
    2), before any config is read or any cluster contacted."""
    if args.workers is not None and args.workers < 1:
        return f"--workers must be 1 or more, not {args.workers}"
    if not args.connect_timeout > 0:
        return f"--connect-timeout must be above 0 s, not {args.connect_timeout:g}"
    if args.scheduler is not None:
        from mapr_daemon.fleet.cluster import scheduler_problem

        return scheduler_problem(args.scheduler)
    return None


def run(args: argparse.Namespace) -> int:
    from mapr_daemon.fleet.cluster import close_client, remote_client, silence_dask_logs

    configs = _configs(args).absolute()
    silence_dask_logs()   # a lost cluster is said in one line, not in Dask's tracebacks
    # an existing scheduler is reached first (ClusterError, exit 69, within the connect
    # timeout); a local cluster is started once the configs and the catalog are good
    client = remote_client(args.scheduler, args.connect_timeout) if args.scheduler else None
    try:
        return _run(args, configs, client)
    finally:
        if client is not None:
            close_client(client)


def _run(args: argparse.Namespace, configs: Any, client: Any) -> int:
    from mapr_daemon.catalog import CatalogWriter
    from mapr_daemon.fleet.archive import DEFAULT_PATTERN, discover
    from mapr_daemon.fleet.cluster import close_client
    from mapr_daemon.fleet.runner import FleetRun
    from mapr_daemon.fleet.task import with_channels
    from mapr_daemon.pipeline.pipeline import build_pipeline

    for config in {c.digest(): c for c in configs.configs()}.values():
        build_pipeline(config)   # every config error before any work: exit 78
    recordings, unusable = discover(args.archive, args.pattern or DEFAULT_PATTERN,
                                    args.tail_tmats)
    for bad in unusable:
        print(f"mapr fleet: {bad.path}: {bad.reason}", file=sys.stderr)
    path = args.catalog or configs.default.catalog.path
    try:
        catalog = CatalogWriter(path, durability=configs.default.catalog.durability,
                                clear_after=configs.default.catalog.episode_clear_bits)
    except CatalogError as error:
        print(f"mapr fleet: {error}", file=sys.stderr)
        return exitcodes.NOINPUT
    local = client is None
    with catalog:
        if local:
            client = _local_client(args)
        started = time.monotonic()
        progress = _progress(args)
        fleet = FleetRun(client, catalog, configs,
                         on_stored=lambda r: progress.add(r.flight_hours, r.ok),
                         on_start=progress.start, channels=args.c10_channels)
        catalog.open_session(backend="fleet",
                             config_hash=with_channels(configs.digest(), args.c10_channels))
        try:
            summary = fleet.run(recordings)
            progress.show(final=True)
        except KeyboardInterrupt:
            catalog.close("interrupted")
            return exitcodes.INTERRUPTED
        except ClusterError as error:
            catalog.close("scheduler lost")
            print(f"mapr fleet: {error}", file=sys.stderr)
            return exitcodes.UNAVAILABLE
        finally:
            if local:
                close_client(client)
        session = catalog.session_id
        catalog.close("fleet run complete")
    for damaged in summary.damaged:
        print(f"mapr fleet: {damaged}", file=sys.stderr)
    for failed in summary.failed:
        print(f"mapr fleet: {failed.recording.path}: {failed.error}", file=sys.stderr)
    print(_summary(summary, recordings, len(unusable), time.monotonic() - started)
          + f"\ncatalog {Path(path)}: session {session}")
    return exitcodes.DATAERR if summary.failed or unusable else exitcodes.OK


def _local_client(args: argparse.Namespace) -> Any:
    """A local cluster of ``--workers`` processes; its dashboard address printed when bokeh
    is installed to serve it, and said not to be otherwise."""
    from mapr_daemon.fleet.cluster import dashboard_available, local_client

    client = local_client(args.workers)
    workers = len(client.scheduler_info()["workers"])
    where = (f"dashboard {client.dashboard_link}" if dashboard_available() else
             "no dashboard (it needs bokeh: pip install 'mapr[dashboard]')")
    print(f"mapr fleet: local Dask cluster, {workers} workers, {where}", file=sys.stderr)
    return client


def _progress(args: argparse.Namespace) -> Any:
    from mapr_daemon.fleet.progress import FleetProgress

    progress = FleetProgress(sys.stderr, 0, 0.0, tty=sys.stderr.isatty(),
                             enabled=args.progress is not False)
    if args.progress:
        progress.tty = True
    return progress


def _summary(summary: Any, recordings: list[Any], unnamed: int, wall: float) -> str:
    """The run in four lines; its counts add up: every file found is a recording, stored,
    already in the catalog or failed (those whose tail and flight could not be told among
    the failed)."""
    tails = len({r.tail for r in recordings})
    tasks = summary.task_s
    cost = (f", per task {statistics.fmean(tasks):.2f} s mean, {max(tasks):.2f} s worst"
            if tasks else "")
    named = f"{len(recordings) + unnamed} recordings of {tails} tails"
    if unnamed:
        named = (f"{len(recordings) + unnamed} recordings ({len(recordings)} of {tails} "
                 f"tails, {unnamed} with no tail and flight in their path)")
    return (f"fleet: {named}: {summary.stored} stored, {summary.skipped} already in the "
            f"catalog"
            + (f" ({summary.stale} with another config)" if summary.stale else "")
            + f", {len(summary.failed) + unnamed} failed\n"
            f"diagnosis: {summary.bits} built-in tests ({summary.rul} with a RUL), "
            f"{summary.events} anomaly events, "
            f"{summary.reasoner_failures} reasoner failures, {summary.damaged_packets} damaged "
            f"packets skipped\n"
            f"{summary.hours:.1f} flight hours in {wall:.1f} s "
            f"({summary.hours / (wall / 3600.0) if wall > 0 else 0.0:.0f} flight h per wall h)"
            f"{cost}")
