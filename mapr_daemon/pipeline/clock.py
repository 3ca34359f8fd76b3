"""Bus time and absolute time of a session: how an event is stamped.

Every event carries two stamps (:class:`~mapr_daemon.catalog.Event`): ``bus_ns``, the time
tag of the record it rests on (for a BIT, the record that carried the request), and
``abs_ns``, that instant in ns since 1970 UTC where it is known. Both are rounded to
:data:`STAMP_NS`, the 100 ns a Chapter 10 recording keeps, so replaying the daemon's own
recording of a flight stamps its events exactly as the daemon did.

:class:`BusClock` maps bus time to absolute time, one per session, by the same rule the
daemon's recorder (:mod:`~mapr_daemon.service.recorder`) writes into its time packets:

* ``live`` (the daemon on a backend): time tags above :data:`WALL_CLOCK_NS` are already
  wall-clock ns (serial and USB cards stamp host time): absolute = the tag. Bus-time tags
  (loopback, capture: ns from 0) get an anchor, the wall clock at the session's first record
  truncated to the 10 ms a time packet holds, as absolute time of bus time 0; a bus time that
  runs back by more than a second (the backend reopened, its clock restarted) gets a new one.
* ``recording`` (``mapr replay``, the ``chapter10`` backend): the records' ``epoch_ns``,
  which the Chapter 10 reader derives from the file's time packets; unknown (None) before the
  first time packet or when the packets give no full date (day of year without ``--year``).

A recording of a wall-clock backend is rebased to its first whole second (the recorder's
rule), so its replay keeps ``abs_ns`` but its ``bus_ns`` counts from that second.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from datetime import UTC, datetime, timedelta
from typing import Literal

from drivers.chapter10.ms1553_batch import NO_EPOCH, Ms1553Batch
from drivers.chapter10.timebase import RTC_NS
from drivers.mil1553.record import MonitorRecord

STAMP_NS = RTC_NS
"""Resolution of an event's stamps: the Chapter 10 relative time counter's 100 ns."""
ANCHOR_NS = 10_000_000
"""Resolution of a time packet (10 ms): a bus-time anchor is truncated to it."""
WALL_CLOCK_NS = 10**17
"""Time tags above this (1973) are wall-clock ns since the epoch, not bus time from 0."""
BACKWARDS_NS = 1_000_000_000
"""Bus time running back by more than this is a restarted bus clock."""


def traffic_span(records: Sequence[MonitorRecord] | Ms1553Batch) -> tuple[int, int]:
    """Bus time tags of the first and the last message of a non-empty batch, records or a
    Chapter 10 reader's columns."""
    if isinstance(records, Ms1553Batch):
        return int(records.t_ns[0]), int(records.t_ns[-1])
    return records[0].t_ns, records[-1].t_ns


def stamp(t_ns: int) -> int:
    """``t_ns`` rounded to :data:`STAMP_NS` as a Chapter 10 writer rounds a time tag."""
    return (int(t_ns) + STAMP_NS // 2) // STAMP_NS * STAMP_NS


class BusClock:
    """Bus time -> absolute time for one session (see the module docstring)."""

    def __init__(self, mode: Literal["live", "recording"] = "live",
                 now_ns: Callable[[], int] = time.time_ns) -> None:
        self.mode = mode
        self.now_ns = now_ns
        self.offset_ns: int | None = None
        """Absolute ns minus bus ns (None: unknown)."""
        self.anchor_ns: int | None = None
        """Live, bus-time tags: the absolute time of bus time 0 (a multiple of 10 ms)."""
        self._last_ns: int | None = None

    def observe(self, records: Sequence[MonitorRecord] | Ms1553Batch) -> None:
        """Take a batch of records (in time order; or a Chapter 10 reader's batch of
        columns) before anything is stamped from it."""
        if not len(records):
            return
        first_ns, last_ns = traffic_span(records)
        if isinstance(records, Ms1553Batch):
            epochs = records.epoch_ns
            epoch: object = None if epochs is None or epochs[-1] == NO_EPOCH else \
                int(epochs[-1])
        else:
            epoch = records[-1].extra.get("epoch_ns")
        if self.mode == "recording":
            if isinstance(epoch, int):
                self.offset_ns = epoch - int(last_ns)
            return
        if first_ns >= WALL_CLOCK_NS:
            self.offset_ns, self.anchor_ns = 0, None
        elif self.anchor_ns is None or self.offset_ns != self.anchor_ns or \
                (self._last_ns is not None and first_ns < self._last_ns - BACKWARDS_NS):
            now = int(self.now_ns())
            self.anchor_ns = now - now % ANCHOR_NS
            self.offset_ns = self.anchor_ns
        self._last_ns = int(last_ns)

    def absolute(self, bus_ns: int) -> int | None:
        """Absolute ns since 1970 UTC of bus time ``bus_ns`` (None while unknown)."""
        return None if self.offset_ns is None else self.offset_ns + int(bus_ns)

    def anchor(self) -> datetime | None:
        """The anchor as a UTC datetime (what the recorder writes as the file's start)."""
        if self.anchor_ns is None:
            return None
        return datetime(1970, 1, 1, tzinfo=UTC) + timedelta(microseconds=self.anchor_ns // 1000)
