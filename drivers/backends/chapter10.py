"""The ``chapter10`` backend: replays the 1553 traffic of an IRIG 106 Chapter 10 recording.

    open_monitor("chapter10", path="flight.c10")                      # as fast as possible
    open_monitor("chapter10", path="flight.c10", channels=[3], speed=1.0)  # in recorded time

``channels`` are the Chapter 10 channel IDs to read (a list, or text ``"2,3"``; default:
every MS1553F1 channel); each record names its channel in ``record.extra["channel"]``.
``name`` is what warnings call the input (default: ``path``; ``mapr replay -`` says
``stdin``). ``speed`` None or 0 replays as fast as the file reads; 1.0 paces records to
the recorded time (from the first record); 2.0 twice as fast. Damaged packets are skipped
and listed in :attr:`Chapter10Monitor.issues` (each also logged as a warning with its file
offset); the replay goes on. ``position`` / ``size`` tell how far into the file the replay
is.

As fast as possible (no ``speed``), the reader's merged batches reach the monitor as columns
(:meth:`~drivers.monitor.BusMonitor.batches` hands them out as they are; records are built
from them a batch at a time); paced, as records.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Iterator, Sequence
from typing import Any

from drivers.chapter10.ms1553_batch import Ms1553Batch
from drivers.chapter10.reader import Chapter10Batch, Chapter10Reader
from drivers.chapter10.walker import ReadIssue
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.timing import BusTiming
from drivers.monitor import BusMonitor, MonitorFilter

log = logging.getLogger(__name__)

BATCH_MESSAGES = 8192
"""Messages of consecutive 1553 packets merged into one batch of columns."""


def channel_ids(channels: Sequence[int] | int | str | None) -> list[int] | None:
    """Channel IDs from a list, one number, or text such as ``"2,3"`` (``mapr monitor -o
    channels=2,3``); None for every channel."""
    if channels is None or isinstance(channels, int):
        return None if channels is None else [channels]
    parts = channels.split(",") if isinstance(channels, str) else list(channels)
    try:
        return [int(part) for part in parts]
    except ValueError:
        raise ValueError(f"channels must be channel IDs such as 2,3, not {channels!r}"
                         ) from None


class Chapter10Monitor(BusMonitor):
    """Replay a Chapter 10 file's MIL-STD-1553 messages as if they came off the bus."""

    def __init__(self, *, path: str, channels: Sequence[int] | int | str | None = None,
                 speed: float | None = None, year: int | None = None,
                 timing: BusTiming | None = None,
                 filters: Sequence[MonitorFilter] | None = None, name: str | None = None,
                 **config: Any) -> None:
        super().__init__(filters=filters, **config)
        if speed is not None and speed < 0:
            raise ValueError(f"speed must be 0 or more, not {speed}")
        self.reader = Chapter10Reader(path, channels=channel_ids(channels), arinc429=False,
                                      year=year, timing=timing, name=name)
        self.speed = speed or 0.0
        self._batches: Iterator[Chapter10Batch] = self.reader.batches(BATCH_MESSAGES)
        self._pending: deque[MonitorRecord] = deque()
        self._issues_logged = 0
        self._first_ns: int | None = None
        self._started = 0.0

    @property
    def issues(self) -> list[ReadIssue]:
        """Damaged packets skipped so far, with their file offsets."""
        return self.reader.issues

    @property
    def position(self) -> int:
        """Bytes of the file replayed so far."""
        return self.reader.position

    @property
    def size(self) -> int:
        return self.reader.size

    def _recv_columns(self, timeout: float | None) -> Ms1553Batch | list[MonitorRecord] | None:
        if self.speed:
            return self._recv_internal(timeout)
        if self._pending:   # records already made (by a direct _recv_internal call)
            out = list(self._pending)
            self._pending.clear()
            return out
        batch = next(self._batches, None)
        self._log_issues()
        if batch is None:
            return None
        return [] if batch.ms1553 is None else batch.ms1553

    def _recv_internal(self, timeout: float | None) -> list[MonitorRecord] | None:
        if not self._pending:
            batch = next(self._batches, None)
            self._log_issues()
            if batch is None:
                return None
            self._pending.extend(batch.records)
            if not self._pending:
                return []
        if not self.speed:
            out = list(self._pending)
            self._pending.clear()
            return out
        return self._paced(timeout)

    def _paced(self, timeout: float | None) -> list[MonitorRecord]:
        """The pending records whose recorded time has come; waits for the next one up to
        ``timeout``."""
        if self._first_ns is None:
            self._first_ns = self._pending[0].t_ns
            self._started = time.monotonic()
        due = self._due(self._pending[0])
        wait = due - time.monotonic()
        if wait > 0:
            if timeout is not None and wait > timeout:
                time.sleep(timeout)
                return []
            time.sleep(wait)
        now = time.monotonic()
        out = []
        while self._pending and self._due(self._pending[0]) <= now:
            out.append(self._pending.popleft())
        return out

    def _due(self, record: MonitorRecord) -> float:
        assert self._first_ns is not None
        return self._started + (record.t_ns - self._first_ns) / 1e9 / self.speed

    def _log_issues(self) -> None:
        issues = self.reader.issues
        for issue in issues[self._issues_logged:]:
            log.warning("%s: %s", self.reader.name, issue)
        self._issues_logged = len(issues)

    def _close(self) -> None:
        self.reader.close()
