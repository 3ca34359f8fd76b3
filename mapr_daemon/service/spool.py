"""The daemon's diagnosed BITs held in memory while the catalog cannot be written.

By the time a batch's BITs reach the catalog the trend has moved on: their flights and
health are already counted, so a batch dropped on a failed write (a full disk, the file
locked by a backup, a read-only remount) would be lost for good. The daemon hands every
batch to a :class:`CatalogSpool` instead. A write that fails keeps its batch, and every
later batch queues behind it (oldest first, so episodes and history see the BITs in bus
order); the spool retries on the loop's later turns, after 0.5 s, doubling up to 30 s, and
writes the whole backlog as soon as the catalog takes it again. A failed write is one
rolled-back transaction (:meth:`~mapr_daemon.catalog.CatalogWriter.add_bits`), so a retry
never writes a BIT twice.

Memory is bounded: beyond :data:`BOUND_BITS` held BITs the oldest batches are dropped,
each drop an error log line with what it lost, and the totals are kept
(:attr:`CatalogSpool.dropped_bits`, :attr:`CatalogSpool.dropped_events`). Within the bound
nothing is lost.
"""

from __future__ import annotations

import collections
import dataclasses
import logging
import time
from collections.abc import Callable, Sequence

from mapr_daemon.catalog import BitOutcome, Event
from mapr_daemon.catalog.model import Flight
from mapr_daemon.errors import CatalogError

log = logging.getLogger("mapr")
BOUND_BITS = 10_000
"""BITs held at most (a BIT every 2 s per actuator: hours of a small aircraft's BITs)."""
RETRY_INITIAL_S = 0.5
RETRY_MAX_S = 30.0


@dataclasses.dataclass(frozen=True)
class Written:
    """One batch the catalog took: its anomaly events and their new ids, in order."""

    events: list[Event]
    ids: list[int]


@dataclasses.dataclass(frozen=True)
class _Held:
    outcomes: list[BitOutcome]
    flights: list[Flight]

    @property
    def events(self) -> list[Event]:
        return [o.event for o in self.outcomes if o.event is not None]


Write = Callable[[list[BitOutcome], list[Flight]], list[int]]
"""Stores one batch in one transaction and returns its event ids (``add_bits``)."""


class CatalogSpool:
    """Batches of diagnosed BITs on their way to the catalog, held while writes fail."""

    def __init__(self, write: Write, *, bound_bits: int = BOUND_BITS,
                 retry_initial_s: float = RETRY_INITIAL_S, retry_max_s: float = RETRY_MAX_S,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._write = write
        self.bound_bits = bound_bits
        self.retry_initial_s = retry_initial_s
        self.retry_max_s = retry_max_s
        self._clock = clock
        self._held: collections.deque[_Held] = collections.deque()
        self._delay = retry_initial_s
        self._next_try = 0.0
        self._failing = False
        self.dropped_bits = 0
        """BITs dropped because the spool was full (and their events below), in all."""
        self.dropped_events = 0

    @property
    def held_bits(self) -> int:
        """BITs waiting for the catalog."""
        return sum(len(h.outcomes) for h in self._held)

    @property
    def held_events(self) -> int:
        """Anomaly events among them."""
        return sum(len(h.events) for h in self._held)

    def submit(self, outcomes: Sequence[BitOutcome], flights: Sequence[Flight] = ()
               ) -> list[Written]:
        """Queue one batch behind any held ones and write what is due now (everything, when
        nothing is held); returns the batches the catalog took, oldest first."""
        if not outcomes and not flights:
            return []
        retrying = bool(self._held)
        self._held.append(_Held(list(outcomes), list(flights)))
        self._enforce_bound()
        if retrying and self._clock() < self._next_try:
            return []
        return self.flush()

    def retry(self) -> list[Written]:
        """Write the held batches if their retry is due (call it on every loop turn)."""
        if not self._held or self._clock() < self._next_try:
            return []
        return self.flush()

    def due_in(self) -> float | None:
        """Seconds until the next retry (0: due; None: nothing held)."""
        if not self._held:
            return None
        return max(0.0, self._next_try - self._clock())

    def flush(self) -> list[Written]:
        """Write held batches oldest first until one fails (it stays, with every later one,
        and the next retry backs off) or none are left."""
        written: list[Written] = []
        while self._held:
            batch = self._held[0]
            try:
                ids = self._write(batch.outcomes, batch.flights)
            except CatalogError as error:
                self._next_try = self._clock() + self._delay
                log.error("catalog: %s; %d BITs (%d events) held, retrying in %.1f s",
                          error, self.held_bits, self.held_events, self._delay)
                self._delay = min(self._delay * 2, self.retry_max_s)
                self._failing = True
                return written
            self._held.popleft()
            written.append(Written(batch.events, ids))
        if self._failing:
            log.warning("catalog writable again: %d held batches written", len(written))
        self._delay, self._next_try, self._failing = self.retry_initial_s, 0.0, False
        return written

    def _enforce_bound(self) -> None:
        """Drop the oldest batches while more than :attr:`bound_bits` BITs are held."""
        while self._held and self.held_bits > self.bound_bits:
            lost = self._held.popleft()
            self.dropped_bits += len(lost.outcomes)
            self.dropped_events += len(lost.events)
            log.error("catalog spool full (%d BITs): dropped the oldest batch, %d BITs and "
                      "%d events never written (%d BITs, %d events dropped in all)",
                      self.bound_bits, len(lost.outcomes), len(lost.events),
                      self.dropped_bits, self.dropped_events)
