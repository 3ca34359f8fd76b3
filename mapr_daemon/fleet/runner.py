"""A fleet run: one Dask task per recording, the client alone writing the catalog in order.

::

    recordings (archive.discover) -> skip those the catalog holds as done
      -> client.submit(process_recording, Job) per recording  (workers: read + reasoner,
         of the 1553 channels asked for, or all)
      -> as each finishes: buffered per tail until every earlier flight of that tail is
         stored, then trended on the client (:mod:`.trend`: the tail's flight declared, each
         BIT's SoH and RUL from the tail's history) and stored
         (catalog.recordings.store_recording: its row, its BITs and its flight in one
         transaction), so per-actuator episodes and trends see flights in order.

Idempotent: a recording stored as done is skipped by a later run, and refused by the store
itself if two runs race. Resumable: a run stopped anywhere leaves whole recordings in the
catalog, and the next does only the rest. A worker killed mid-task loses nothing: tasks
write nothing, and the Dask scheduler runs a lost task again on another worker. A task's
key is derived from the recording's digest and its configuration, so the scheduler never
runs the same work twice at once.

The cluster is the caller's (:mod:`.cluster`: a local one, or a client of a scheduler).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Collection, Sequence
from typing import TYPE_CHECKING, Any

from mapr_daemon.catalog import BitOutcome
from mapr_daemon.catalog.model import Flight, InflightEstimate
from mapr_daemon.catalog.recordings import DONE, FAILED, RecordingRow, store_recording, stored
from mapr_daemon.catalog.writer import CatalogWriter
from mapr_daemon.errors import ClusterError
from mapr_daemon.fleet.archive import Recording
from mapr_daemon.fleet.cluster import reason
from mapr_daemon.fleet.config import FleetConfig
from mapr_daemon.fleet.task import Job, TaskResult, process_recording, with_channels
from mapr_daemon.fleet.trend import FleetTrend

if TYPE_CHECKING:
    from distributed import Client


@dataclasses.dataclass
class RunSummary:
    """What one run did."""

    total: int = 0
    """Recordings found."""
    skipped: int = 0
    """Already stored as done by an earlier run."""
    stale: int = 0
    """Among the skipped, those stored with another configuration (a fresh catalog re-runs
    them)."""
    stored: int = 0
    failed: list[TaskResult] = dataclasses.field(default_factory=list)
    events: int = 0
    bits: int = 0
    rul: int = 0
    """Stored BITs the trend gave a remaining useful life."""
    hours: float = 0.0
    reasoner_failures: int = 0
    damaged_packets: int = 0
    damaged: list[str] = dataclasses.field(default_factory=list)
    """Each damaged packet skipped, as ``path: offset N: what``, in the order stored."""
    task_s: list[float] = dataclasses.field(default_factory=list)


def task_key(recording: Recording, config_digest: str) -> str:
    return f"mapr-fleet-{recording.digest[:24]}-{config_digest}"


class FlightOrder:
    """Holds finished recordings back until every earlier flight of their tail is out.

    Built from the recordings to run (sorted by tail and flight); :meth:`ready` takes one
    finished result and returns those that may be stored now, in flight order."""

    def __init__(self, recordings: Sequence[Recording]) -> None:
        self.queues: dict[str, list[str]] = {}
        for recording in sorted(recordings, key=lambda r: (r.tail, r.flight, r.path)):
            self.queues.setdefault(recording.tail, []).append(recording.digest)
        self.waiting: dict[str, TaskResult] = {}

    def ready(self, result: TaskResult) -> list[TaskResult]:
        self.waiting[result.recording.digest] = result
        queue = self.queues[result.recording.tail]
        out = []
        while queue and queue[0] in self.waiting:
            out.append(self.waiting.pop(queue.pop(0)))
        return out


class FleetRun:
    """Submits the work and stores the results (see the module docstring). ``channels``: the
    1553 channel IDs every task reads (``mapr fleet --c10-channel``; None: all of them)."""

    def __init__(self, client: Client, catalog: CatalogWriter, configs: FleetConfig,
                 on_stored: Callable[[TaskResult], None] | None = None,
                 on_start: Callable[[Sequence[Recording]], None] | None = None, *,
                 channels: Collection[int] | None = None) -> None:
        """``on_start`` is called with the recordings to process (those the catalog does not
        hold yet) before any is submitted, ``on_stored`` with each result once stored."""
        self.client, self.catalog, self.configs = client, catalog, configs
        self.on_stored, self.on_start = on_stored, on_start
        self.channels = frozenset(channels) if channels else None
        self.summary = RunSummary()
        self.trend = FleetTrend(catalog, configs)

    def pending(self, recordings: Sequence[Recording]) -> list[Recording]:
        """The recordings the catalog does not hold as done."""
        known = stored(self.catalog)
        out = []
        for recording in recordings:
            row = known.get(recording.digest)
            if row is not None and row.status == DONE:
                self.summary.skipped += 1
                self.summary.stale += row.config_digest != self.digest(recording.tail)
            else:
                out.append(recording)
        return out

    def digest(self, tail: str) -> str:
        """What ``tail``'s recordings are processed with: its config's content digest, the
        channel pick folded in (:func:`~mapr_daemon.fleet.task.with_channels`)."""
        return with_channels(self.configs.digest(tail), self.channels)

    def run(self, recordings: Sequence[Recording]) -> RunSummary:
        """Process every recording not yet stored; returns the summary.

        Raises :class:`~mapr_daemon.errors.ClusterError` when the connection to the
        scheduler is lost (what was stored stays stored). A task that kept killing its
        workers (Dask's ``KilledWorker``) is stored as a failed recording, naming that."""
        from distributed import as_completed

        self.summary.total = len(recordings)
        todo = self.pending(recordings)
        if self.on_start is not None:
            self.on_start(todo)
        order = FlightOrder(todo)
        futures = {}
        for recording in todo:
            config, digest = self.configs.for_tail(recording.tail), self.digest(recording.tail)
            future = self.client.submit(process_recording,
                                        Job(recording, config, digest, self.channels),
                                        key=task_key(recording, digest), retries=1)
            futures[future.key] = (future, recording, digest)
        for future in as_completed([f for f, _, _ in futures.values()]):  # type: ignore[no-untyped-call]
            _, recording, digest = futures[future.key]
            for result in order.ready(self._result(future, recording, digest)):
                self._store(result)
        return self.summary

    def _result(self, future: Any, recording: Recording, digest: str) -> TaskResult:
        """The task's result; a lost scheduler raised as ClusterError, any other failure of
        the task itself (it killed its workers) as a failed result."""
        from concurrent.futures import CancelledError

        try:
            result: TaskResult = future.result()
        except (CancelledError, OSError) as error:   # CommClosedError is an OSError
            address = getattr(self.client, "scheduler", None)
            raise ClusterError(f"lost the connection mid-run ({reason(error)}); "
                               f"{self.summary.stored} recordings stored, run again to "
                               f"resume", address=getattr(address, "address", None)) from None
        except Exception as error:   # KilledWorker, or the task could not be unpickled
            return TaskResult(recording, digest, False, f"{type(error).__name__}: "
                                                        f"{reason(error)}")
        return result

    def _store(self, result: TaskResult) -> None:
        recording, summary = result.recording, self.summary
        row = RecordingRow(recording.digest, recording.path, recording.tail, recording.flight,
                           result.flight_hours, DONE if result.ok else FAILED,
                           result.config_digest, result.error, len(result.outcomes),
                           result.events)
        outcomes: list[BitOutcome] = []
        flights: list[Flight] = []
        inflight: list[InflightEstimate] = []
        if result.ok:
            outcomes, flights, inflight = self.trend.flight(
                recording.tail, recording.flight, result.flight_hours, result.outcomes,
                result.inflight)
        if store_recording(self.catalog, row, outcomes, flights, inflight):
            if result.ok:
                summary.stored += 1
                summary.events += result.events
                summary.bits += len(outcomes)
                summary.rul += sum(o.health is not None and o.health.rul is not None
                                   for o in outcomes)
                summary.hours += result.flight_hours
            else:
                summary.failed.append(result)
            summary.reasoner_failures += len(result.failures)
            summary.damaged_packets += len(result.issues)
            summary.damaged += [f"{recording.path}: {issue}" for issue in result.issues]
            summary.task_s.append(result.task_s)
        else:
            summary.skipped += 1
            self.trend.forget(recording.tail)   # its trend ran ahead of the catalog
        if self.on_stored is not None:
            self.on_stored(result)
