"""``mapr replay``: run a Chapter 10 recording through the daemon's pipeline, to the catalog.

::

    mapr replay flight.c10                                  # messages, ICD, bus statistics
    mapr replay flight.c10 --diagnose --dictionary dictionary.npz --catalog replay.db
    mapr replay flight.c10 --speed 1 --c10-channel 3        # in recorded time, one channel
    cat flight.c10 | mapr replay -                          # a stream on stdin

The recording's 1553 messages go monitor -> ICD -> (with ``--diagnose``) BIT watch and
reasoner -> fault catalog, as in ``mapr run``, in one catalog session (backend
``chapter10``). A progress bar (by file position) goes to stderr when it is a terminal, and a
summary to stdout at the end. With ``--diagnose``, a recording holding none of the ICD's
actuator signals says so instead of diagnosing nothing in silence. Damaged packets are
skipped, named on stderr and recorded as catalog gaps. Each batch goes through the daemon's
own path (:meth:`mapr_daemon.pipeline.pipeline.Pipeline.process`), so events carry the same
fields and stamps as the daemon wrote for that traffic: bus time, and the recording's absolute
time when its time packets give a full date (``t_ns`` falls back to the replay's wall clock
when they do not). Each event's evidence also names the recording.

Exit codes: 0 done; 2 the file cannot be read or is not Chapter 10; 65 it holds no 1553
data, or none on an asked ``--c10-channel`` (one line says what it holds); 66 the catalog
cannot be opened; 78 a config, ICD or dictionary error (``--diagnose`` without a dictionary).
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from mapr_daemon.cli import exitcodes
from mapr_daemon.cli.traffic.source import add_c10_channel_argument
from mapr_daemon.cli.validate import bounded_int
from mapr_daemon.errors import CatalogError, ConfigError

if TYPE_CHECKING:
    from drivers.mil1553.record import MonitorRecord
    from mapr_daemon.catalog import CatalogWriter
    from mapr_daemon.catalog.model import InflightEstimate
    from mapr_daemon.cli.traffic.source import Chapter10Input
    from mapr_daemon.pipeline.pipeline import Batch, Pipeline
    from mapr_daemon.service.config import Config

BATCH = 1024
"""Records handed to the ICD and reasoner at a time when paced (``--speed``)."""
COLUMNS = BATCH
"""Messages read and handed on at a time as fast as the file reads, as columns: no more than
when paced, since a damaged packet's catalog gap is stamped with the bus time of the batch it
was met in (a larger batch would stamp it later)."""

log = logging.getLogger("drivers.backends.chapter10")
"""The damaged packets are named under the backend's logger, as when it reads them."""


def add_subparser(subparsers: Any) -> None:
    p = subparsers.add_parser("replay", help="run a Chapter 10 recording through the reasoner "
                                             "into the catalog",
                              description=__doc__,
                              formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("recording", help="IRIG 106 Chapter 10 file, or '-' for a stream on stdin")
    p.add_argument("--config", metavar="FILE", help="daemon config to start from (assets, "
                                                    "reasoner, catalog; default: defaults)")
    p.add_argument("--icd", metavar="FILE", help="message table (default: the config's)")
    p.add_argument("--diagnose", action="store_true",
                   help="run the reasoner on the built-in tests found in the recording")
    p.add_argument("--dictionary", metavar="FILE", help="fault dictionary for --diagnose "
                                                        "(default: the config's)")
    p.add_argument("--threshold", type=float, help="anomaly threshold override")
    p.add_argument("--catalog", metavar="PATH", help="fault catalog (default: the config's)")
    p.add_argument("--speed", type=float, default=0.0, metavar="X",
                   help="0: as fast as possible (default); 1: in recorded time; 2: twice as "
                        "fast")
    add_c10_channel_argument(p, "replay only this 1553 channel ID (repeat for more)")
    p.add_argument("--year", type=bounded_int(1970, 2199, "year"),
                   help="year of day-of-year time packets")
    p.add_argument("--tail", help="the aircraft's tail number (default: the config's "
                                  "aircraft.tail)")
    p.add_argument("--flight", type=bounded_int(1, 10**7, "flight number"), metavar="N",
                   help="the recording is this flight of the aircraft (default: flights told "
                        "from the traffic's gaps, aircraft.flight_gap_s)")
    p.add_argument("--flight-hours", type=float, metavar="H",
                   help="with --flight: its length in hours (default: the recording's span)")
    bar = p.add_mutually_exclusive_group()
    bar.add_argument("--progress", action="store_true", default=None,
                     help="show the progress bar even when stderr is not a terminal")
    bar.add_argument("--no-progress", action="store_false", dest="progress")
    p.set_defaults(func=run)


class ProgressBar:
    """``[#####-----]  48%  512 KiB / 1.0 MiB  1234 messages`` on one rewritten line."""

    def __init__(self, out: TextIO, size: int, enabled: bool, width: int = 30) -> None:
        self.out, self.size, self.enabled, self.width = out, max(size, 1), enabled, width
        self._last = 0.0

    def show(self, position: int, messages: int, *, final: bool = False) -> None:
        now = time.monotonic()
        if not self.enabled or (not final and now - self._last < 0.1):
            return
        self._last = now
        share = min(1.0, position / self.size)
        done = round(share * self.width)
        self.out.write(f"\r[{'#' * done}{'-' * (self.width - done)}] {share:4.0%}  "
                       f"{_size(position)} / {_size(self.size)}  {messages} messages")
        if final:
            self.out.write("\n")
        self.out.flush()


def _size(n: int) -> str:
    return f"{n / 2**20:.1f} MiB" if n >= 2**20 else f"{n / 2**10:.0f} KiB"


def run(args: argparse.Namespace) -> int:
    path = Path(args.recording)
    if args.flight_hours is not None and (args.flight is None or not args.flight_hours > 0
                                          or args.flight_hours > 1000):
        print("mapr replay: --flight-hours needs --flight and a length in (0, 1000] hours",
              file=sys.stderr)
        return exitcodes.USAGE
    if args.threshold is not None and not args.threshold > 0:
        print(f"mapr replay: --threshold must be above 0, not {args.threshold}",
              file=sys.stderr)
        return exitcodes.USAGE
    from drivers.errors import CaptureFormatError
    from mapr_daemon.cli.traffic.source import chapter10_input
    found = chapter10_input(args.recording)   # '-': a stream on stdin, spooled
    if found is None:
        name = "stdin" if args.recording == "-" else str(path)
        raise CaptureFormatError(f"{name}: not a Chapter 10 recording (no packet header at "
                                 "its start)" if args.recording == "-" or path.is_file()
                                 else f"{name}: no such file")
    try:
        return _replay(args, found)
    finally:
        found.done_opening()   # a spooled stream's copy never outlives the command


def _replay(args: argparse.Namespace, found: Chapter10Input) -> int:
    """Replay the recording ``found`` (a file, or a stream's spooled copy), called by its
    name (the path given, or ``stdin``) in every message and in the catalog."""
    from mapr_daemon.cli.traffic.source import what_it_holds
    from mapr_daemon.pipeline.pipeline import build_pipeline
    from mapr_daemon.service.config import load_config

    path = Path(found.name)
    config = load_config(args.config)
    reasoner = config.reasoner
    if args.dictionary:
        reasoner = dataclasses.replace(reasoner, dictionary=args.dictionary)
    if args.threshold is not None:
        reasoner = dataclasses.replace(reasoner, threshold=args.threshold)
    if not args.diagnose:   # no reasoner at all: neither the one for all nor an asset's
        reasoner = dataclasses.replace(reasoner, dictionary=None)
        config = dataclasses.replace(config, assets=tuple(
            dataclasses.replace(a, dictionary=None) for a in config.assets))
    elif reasoner.dictionary is None and not any(a.dictionary for a in config.assets):
        raise ConfigError("--diagnose needs a fault dictionary: --dictionary FILE (or "
                          "reasoner.dictionary or assets[].dictionary in --config)")
    options = {"path": found.path, "name": found.name, "channels": args.c10_channels,
               "speed": args.speed, "year": args.year}
    aircraft = config.aircraft if args.tail is None else \
        dataclasses.replace(config.aircraft, tail=args.tail)
    config = dataclasses.replace(
        config, icd=args.icd or config.icd, reasoner=reasoner, aircraft=aircraft,
        catalog=dataclasses.replace(config.catalog, path=args.catalog or config.catalog.path),
        backend=dataclasses.replace(config.backend, name="chapter10", options=options))
    from mapr_daemon.service import logs
    logs.setup("warning")
    pipe = build_pipeline(config)
    try:
        from mapr_daemon.catalog import CatalogWriter
        catalog = CatalogWriter(config.catalog.path,
                                durability=config.catalog.durability,  # type: ignore[arg-type]
                                clear_after=config.catalog.episode_clear_bits)
    except CatalogError as error:
        print(f"mapr replay: {error}", file=sys.stderr)
        return exitcodes.NOINPUT
    pipe.resume(*catalog.history(config.aircraft.tail))   # continue each actuator's trend
    if args.flight is not None:
        pipe.declare_flight(args.flight, args.flight_hours)
    replay = Replay(pipe, catalog, config, path)
    found.done_opening()   # the reader holds it open: a stream's spooled copy can go
    try:
        replay.run(args.progress if args.progress is not None else sys.stderr.isatty())
    except KeyboardInterrupt:
        replay.finish("interrupted")
        return exitcodes.INTERRUPTED
    replay.finish("replay complete")
    # no 1553 data, or none on an asked channel: said in one line, naming what it holds
    return what_it_holds(replay.monitor.reader, args.c10_channels, "mapr replay")


class Replay:
    """The daemon's per-batch path (:meth:`Pipeline.process`), run to the end of a file."""

    def __init__(self, pipe: Pipeline, catalog: CatalogWriter, config: Config, path: Path
                 ) -> None:
        self.pipe, self.catalog, self.config, self.path = pipe, catalog, config, path
        from drivers.backends.chapter10 import Chapter10Monitor
        from drivers.monitor import BusStatistics, open_monitor
        from mapr_daemon.pipeline.clock import BusClock
        self.stats = BusStatistics()
        self.events = 0
        self.inflight_rows = 0
        self.error_messages = 0
        self.issues_seen = 0
        self.clock = BusClock("recording")
        self.actuator_seen = False
        self.started_ns = time.time_ns()
        monitor = open_monitor("chapter10", **config.backend.options)
        assert isinstance(monitor, Chapter10Monitor)
        self.monitor = monitor
        catalog.open_session(backend="chapter10", config_hash=config.digest())

    def run(self, progress: bool) -> None:
        bar = ProgressBar(sys.stderr, self.monitor.size, progress)
        if not self.monitor.speed:
            self._run_columns(bar)
            return
        batch: list[MonitorRecord] = []
        while True:
            record = self.monitor.recv(timeout=0.2)
            if record is not None:
                batch.append(record)
            if record is None or len(batch) >= BATCH:
                self.process(batch)
                batch = []
                bar.show(self.monitor.position, sum(self.stats.messages.values()))
            if record is None and self.monitor.ended:
                break
        bar.show(self.monitor.size, sum(self.stats.messages.values()), final=True)

    def _run_columns(self, bar: ProgressBar) -> None:
        """As fast as the file reads: the reader's merged batches, each handed to the
        pipeline as columns (no record object per message; decoded as the records would be,
        mapr_daemon/icd/columns.py); the damaged packets named on stderr here, as the
        monitor would have named them."""
        import numpy as np

        last = 0
        for batch in self.monitor.reader.batches(COLUMNS):
            columns = batch.ms1553
            if columns is not None and len(columns):
                self.stats.add_columns(columns)
                self.error_messages += int(np.count_nonzero(columns.errors))
                last = int(columns.t_ns[-1])
                self._store(self.pipe.process(columns, self.clock), last, log_issues=True)
            bar.show(self.monitor.position, sum(self.stats.messages.values()))
        self._gaps(last, log_issues=True)
        bar.show(self.monitor.size, sum(self.stats.messages.values()), final=True)

    def process(self, records: list[MonitorRecord]) -> None:
        for record in records:
            self.stats.add(record)
            self.error_messages += bool(record.errors)
        self._store(self.pipe.process(records, self.clock),
                    records[-1].t_ns if records else 0)

    def _store(self, result: Batch, bus_ns: int, *, log_issues: bool = False) -> None:
        """A processed batch into the catalog: the gaps met up to ``bus_ns``, the reasoner's
        failures, the BITs with their events."""
        self._gaps(bus_ns, log_issues=log_issues)
        self.actuator_seen |= result.actuator_seen
        for failure in result.failures:
            at = self._when(failure.bus_ns)
            self.catalog.record_gap(at, at, f"reasoner failed on a BIT: {failure.error}")
        outcomes = [o if o.event is None else dataclasses.replace(o, event=dataclasses.replace(
            o.event, evidence={**o.event.evidence, "recording": str(self.path)}))
            for o in result.outcomes]
        if outcomes:  # the events, and every BIT's effect on the fault episodes
            self.events += len(self.catalog.add_bits(outcomes, result.flights))
        self._inflight(result.inflight)

    def _inflight(self, rows: list[InflightEstimate]) -> None:
        """Flights' in-flight rows into the catalog (docs/reasoner.md, in-flight tracking)."""
        if rows:
            self.catalog.add_inflight(rows)
            self.inflight_rows += len(rows)

    def _when(self, bus_ns: int) -> int:
        absolute = self.clock.absolute(bus_ns)
        return time.time_ns() if absolute is None else absolute

    def _gaps(self, bus_ns: int, *, log_issues: bool = False) -> None:
        """Each damaged packet met since the last call as a catalog gap (and on stderr when
        ``log_issues``: the monitor logs those it reads itself)."""
        issues = self.monitor.issues
        for issue in issues[self.issues_seen:]:
            if log_issues:
                log.warning("%s: %s", self.path, issue)
            at = self._when(bus_ns)
            self.catalog.record_gap(at, at, f"{self.path.name}: {issue}")
        self.issues_seen = len(issues)

    def finish(self, reason: str) -> None:
        """Statistics and session end in the catalog; the summary on stdout."""
        self.monitor.close()
        stats = self.stats
        first = min(stats.first_ns.values(), default=0)
        last = max(stats.last_ns.values(), default=0)
        if stats.messages:
            offset = self.clock.offset_ns
            if offset is not None:
                self.catalog.add_stats(first + offset, last + offset, stats)
            else:
                self.catalog.add_stats(self.started_ns, time.time_ns(), stats)
        self._inflight(self.pipe.end_flight())   # the recording's end ends its flight
        self.catalog.save_flights(self.pipe.pending_flights())
        session = self.catalog.session_id
        self.catalog.close(reason)
        print(self.summary(session, reason))

    def summary(self, session: int | None, reason: str) -> str:
        stats, stream = self.stats, self.pipe.stream.stats
        per_bus = ", ".join(f"bus {b} {n}" for b, n in sorted(stats.messages.items()))
        lines = [f"{self.path}: {reason}: {sum(stats.messages.values())} messages "
                 f"({per_bus or 'none'}), {self.error_messages} with errors, damaged packets "
                 f"skipped: {self.issues_seen}",
                 f"ICD {self.pipe.icd.name}: {stream.decoded} messages decoded, "
                 f"{stream.unmatched} not in the table"]
        if self.pipe.watches:
            if not self.actuator_seen:
                rts = ", ".join(str(t.address) for t in self.pipe.icd.terminals)
                lines.append(f"diagnosis: no actuator of the ICD {self.pipe.icd.name} (RT "
                             f"{rts}) found in the recording: nothing to diagnose")
            else:
                lines.append(f"diagnosis: {self.pipe.bits_seen} built-in tests diagnosed, "
                             f"{self.events} anomaly events written, "
                             f"{self.inflight_rows} in-flight estimates stored (one per "
                             "actuator and flight)")
        lines.append(f"catalog {self.catalog.path}: session {session}")
        return "\n".join(lines)
