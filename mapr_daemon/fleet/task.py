"""One recording through the daemon's records -> events path, on a worker: the fleet's task.

:func:`process_recording` reads a Chapter 10 file with the reader the ``chapter10`` backend
wraps (only the 1553 channels the job names, when it names some), in merged batches of up
to :data:`BATCH` messages held as columns, and hands each to
:meth:`Pipeline.process` (the one path the daemon and ``mapr replay`` run, built by
:func:`build_pipeline`), which decodes the columns as it would their records, without a
record object per message (two thirds of a task's time when it built them; nor are they
taken one at a time from a monitor's queue: a task needs neither its filters nor its bus
statistics), and returns everything the
catalog needs as a picklable :class:`TaskResult`: every diagnosed BIT as a
:class:`~mapr_daemon.catalog.BitOutcome` with its bus and absolute stamps, its tail and its
degradation estimates (the trend, which needs the tail's earlier flights, is the client's:
:mod:`.trend`), the reasoner's failures and the damaged packets skipped.
A task writes nothing: the client alone writes the catalog, so a worker killed mid-task
loses nothing (the scheduler runs the task again elsewhere). Any error reading the file
becomes a failed result naming it, as does a recording without a channel the job asked for
(the result says what the recording holds); the other recordings go on.

A worker keeps the pipelines it built (the dictionary load is the expensive part), one per
configuration; each recording starts from a fresh session (signal stream, BIT watch and
reasoner unit state, :func:`_fresh`), as ``mapr replay`` of that one file would: what
carries from flight to flight is the client's and the catalog's (trends, episodes), in
flight order.
"""

from __future__ import annotations

import dataclasses
import hashlib
import time
import traceback
from collections.abc import Collection

from drivers.chapter10.reader import Chapter10Reader
from drivers.errors import MaprError
from mapr_daemon.catalog import BitOutcome
from mapr_daemon.catalog.model import InflightEstimate
from mapr_daemon.fleet.archive import Recording
from mapr_daemon.pipeline.clock import BusClock
from mapr_daemon.pipeline.pipeline import Pipeline, build_pipeline
from mapr_daemon.service.config import Config

BATCH = 8192
"""Messages read and handed to :meth:`Pipeline.process` at a time: consecutive packets
merged by the reader (:meth:`Chapter10Reader.batches`) into one batch of columns."""


@dataclasses.dataclass(frozen=True)
class Job:
    """What a task is given: the recording, its tail's configuration (every path absolute),
    the digest it is known by (:meth:`FleetConfig.digest`, with the channel pick folded in by
    :func:`with_channels`; computed once on the client and stored with the result) and the
    1553 channels to read (``mapr fleet --c10-channel``; None: every channel)."""

    recording: Recording
    config: Config
    config_digest: str
    channels: frozenset[int] | None = None


def with_channels(config_digest: str, channels: Collection[int] | None) -> str:
    """What a recording was processed with: the config's content digest alone when every
    channel is read (so it is :meth:`FleetConfig.digest` itself, and catalogs stored before
    channels could be picked stay current), else a digest of it and the channels picked,
    since the same file read on other channels is other work (its own task key, and a stored
    row with another pick counts as stale)."""
    if not channels:
        return config_digest
    picked = ",".join(map(str, sorted(set(channels))))
    return hashlib.sha256(f"{config_digest} channels {picked}".encode()).hexdigest()[:16]


@dataclasses.dataclass(frozen=True)
class TaskResult:
    """What a task returns to the client (picklable; nothing is written by the task)."""

    recording: Recording
    config_digest: str
    ok: bool
    error: str | None = None
    outcomes: list[BitOutcome] = dataclasses.field(default_factory=list)
    """Every BIT diagnosed, in time order: plain asset name, ``tail`` set, ``wear`` estimated;
    no flight or health yet (the client trends them)."""
    failures: list[str] = dataclasses.field(default_factory=list)
    """BITs the reasoner failed on (their error), for the run's report."""
    issues: list[str] = dataclasses.field(default_factory=list)
    """Damaged packets skipped (with file offsets)."""
    messages: int = 0
    recorded_s: float = 0.0
    """Bus time from the first record to the last."""
    actuator_seen: bool = False
    task_s: float = 0.0
    inflight: list[InflightEstimate] = dataclasses.field(default_factory=list)
    """Each actuator's in-flight estimate of the recording's flight, its change not yet
    against the unit's baseline (the client's :class:`~.trend.FleetTrend` sets it, in
    flight order)."""
    """Wall time of the task on its worker."""

    @property
    def flight_hours(self) -> float:
        """Declared flight hours, or the recorded time when none were declared."""
        declared = self.recording.flight_hours
        return self.recorded_s / 3600.0 if declared is None else declared

    @property
    def events(self) -> int:
        return sum(o.event is not None for o in self.outcomes)


_PIPELINES: dict[tuple[str, str | None], Pipeline] = {}
"""This worker's pipelines by (config digest, config file)."""


def _fresh(config: Config) -> Pipeline:
    """A pipeline for ``config`` with no state from an earlier recording: the expensive parts
    (ICD, dictionary) come from this worker's cache, the per-session parts are rebuilt."""
    key = (config.digest(), config.source)
    cached = _PIPELINES.get(key)
    if cached is None:
        cached = _PIPELINES[key] = build_pipeline(config, trend=False)
    from mapr_daemon.icd import SignalStream
    from mapr_daemon.pipeline.bitwatch import BitWatch
    from mapr_daemon.pipeline.pipeline import Watched
    from mapr_daemon.reasoner.reasoner import Reasoner
    watched = []
    for w in cached.watched:
        watch = w.watch
        if watch is not None:  # the threshold override is already in the dictionary
            old = watch.reasoner
            # the commissioned baseline too: the client trends with its wear noise
            unit = Reasoner(old.dictionary, old.params, prognostic=old.prognostic,
                            baseline=old.baseline)
            watch = BitWatch(unit, signals=w.asset.signals, bit=old.params.bit,
                             paper=watch.paper)
        watched.append(Watched(w.asset, watch))
    from mapr_daemon.pipeline.pipeline import watch_inflight
    inflight = [watch_inflight(w.asset.name, w.watch) for w in watched
                if w.watch is not None] if cached.inflight else []
    return dataclasses.replace(cached, stream=SignalStream(cached.icd), watched=watched,
                               inflight=inflight, ended=[])


def process_recording(job: Job) -> TaskResult:
    """Run one recording through the pipeline (see the module docstring)."""
    started = time.monotonic()
    recording, config, digest = job.recording, job.config, job.config_digest
    try:
        result = _run(recording, config, digest, job.channels)
    except (MaprError, OSError, ValueError) as error:
        return TaskResult(recording, digest, False, f"{type(error).__name__}: {error}",
                          task_s=time.monotonic() - started)
    except Exception as error:  # a bug on one file must not stop the fleet: named, kept
        where = traceback.format_exception(error)[-2].strip().splitlines()[0]
        return TaskResult(recording, digest, False,
                          f"{type(error).__name__}: {error} ({where})",
                          task_s=time.monotonic() - started)
    return dataclasses.replace(result, task_s=time.monotonic() - started)


def _run(recording: Recording, config: Config, digest: str,
         channels: frozenset[int] | None) -> TaskResult:
    pipe = _fresh(config)
    clock = BusClock("recording")
    outcomes: list[BitOutcome] = []
    failures: list[str] = []
    messages, seen = 0, False
    first: int | None = None
    last = 0
    tail = recording.tail
    reader = Chapter10Reader(recording.path, channels=channels, arinc429=False)
    try:
        for batch in reader.batches(BATCH):
            columns = batch.ms1553
            if columns is None or not len(columns):
                continue
            first = int(columns.t_ns[0]) if first is None else first
            last = int(columns.t_ns[-1])
            messages += len(columns)
            result = pipe.process(columns, clock)
            seen |= result.actuator_seen
            failures += [f.error for f in result.failures]
            outcomes += [_in_fleet(o, tail, recording) for o in result.outcomes]
        inflight = pipe.end_flight()   # the recording is one flight
        issues = [str(issue) for issue in reader.issues]
        absent = sorted(set(channels or ()) - reader.channels_seen)
        if absent:   # as every command reading a recording says it: the channel, what it holds
            from drivers.chapter10.holdings import holdings
            return TaskResult(recording, digest, False,
                              f"channel {', '.join(map(str, absent))} not in the recording "
                              f"(it holds: {holdings(reader)})", issues=issues)
    finally:
        reader.close()
    return TaskResult(recording, digest, True, None, outcomes, failures, issues, messages,
                      0.0 if first is None else (last - first) / 1e9, seen,
                      inflight=[dataclasses.replace(r, tail=tail, flight=recording.flight)
                                for r in inflight])


def _in_fleet(outcome: BitOutcome, tail: str, recording: Recording) -> BitOutcome:
    """The outcome of ``tail``, its event's evidence naming the recording."""
    event = outcome.event
    if event is not None:
        event = dataclasses.replace(event, evidence={
            **event.evidence, "recording": recording.path, "tail": tail,
            "flight": recording.flight})
    return dataclasses.replace(outcome, tail=tail, event=event)
