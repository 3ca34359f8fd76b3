"""The daemon's Chapter 10 recording (config ``record:``): every record it sees, one file per
session, so a flight can be replayed later (``mapr replay``, the ``chapter10`` backend).

Files go to ``record.path`` (a directory, created if missing) as
``session-000042-20260509T143000Z.ch10``: the catalog's session id and the UTC time of the
first record. Written through :class:`~drivers.chapter10.writer.Chapter10Writer`, which closes
a packet at least every 100 ms of recorded time, so a crash loses at most the open packet;
the daemon flushes (fsync) at each statistics interval and closes the file on SIGTERM.

Time base. The writer wants time tags counted from the start of the recording. Backends that
stamp records with wall-clock time (serial: host arrival; usb: the sample counter anchored to
host time) are rebased to the first record's second, and that second becomes the file's
start time; bus-time backends (loopback, capture: ns from 0) start at the wall-clock time of
the first record: the session clock's anchor (:mod:`~mapr_daemon.pipeline.clock`), the very instant
the daemon's
events are stamped from. When time runs backwards — the backend was reopened after a failure and its
bus time restarted — the file is closed and a new part begins (``...-part2.ch10``).

Each file's TMATS setup record names the aircraft (``aircraft.tail``, as ``G\\TA``), as
``mapr record --tail`` does, so ``mapr fleet --tail-tmats 'G\\TA'`` files the recording under
its tail whatever folder it ends up in.

A write error (disk full, the directory removed) is logged once and ends the recording; the
daemon goes on monitoring.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord
from mapr_daemon.pipeline.clock import BACKWARDS_NS, WALL_CLOCK_NS, BusClock

log = logging.getLogger("mapr.record")


class SessionRecorder:
    """Writes a session's records to Chapter 10 files in ``directory``."""

    def __init__(self, directory: str, session_id: int, *, channel_id: int = 1,
                 clock: BusClock | None = None, tail: str = "") -> None:
        self.directory = Path(directory)
        self.tail = tail
        """The aircraft's tail number (``aircraft.tail``), written into each file's TMATS
        (``G\\TA``, where the fleet reader looks for it); none when empty."""
        self.clock = clock
        """The session's clock: a bus-time file starts at its anchor, so the file's time
        packets give the absolute time the daemon stamped its events with."""
        self.session_id = session_id
        self.channel_id = channel_id
        self.files: list[Path] = []
        """Every file this session wrote, in order."""
        self.messages = 0
        self.failed = False
        self._writer: Chapter10Writer | None = None
        self._offset = 0
        self._last_ns = 0

    def write(self, records: Sequence[MonitorRecord]) -> None:
        """Record ``records`` (in time order); never raises: a failure ends the recording."""
        if self.failed or not records:
            return
        try:
            self._write(records)
        except (OSError, ValueError) as error:
            self.failed = True
            log.error("recording stopped: %s", error)
            self._close_quietly()

    def _write(self, records: Sequence[MonitorRecord]) -> None:
        if self._writer is not None and records[0].t_ns < self._last_ns - BACKWARDS_NS:
            self._writer.close()
            self._writer = None
        if self._writer is None:
            self._writer = self._open(records[0].t_ns)
        offset = self._offset
        if offset:
            records = [dataclasses.replace(r, t_ns=r.t_ns - offset,
                                           end_ns=r.end_ns - offset if r.end_ns else 0)
                       for r in records]
        skipped = self._writer.stats.skipped
        self._writer.write(records)
        if self._writer.stats.skipped > skipped:
            log.warning("recording: %d records with a time tag a Chapter 10 file cannot hold "
                        "skipped", self._writer.stats.skipped - skipped)
        self._last_ns = records[-1].t_ns + offset
        self.messages += len(records)

    def _open(self, first_ns: int) -> Chapter10Writer:
        if first_ns >= WALL_CLOCK_NS:
            self._offset = first_ns - first_ns % 1_000_000_000
            start = datetime.fromtimestamp(self._offset / 1e9, UTC)
        else:
            self._offset = 0
            anchor = None if self.clock is None else self.clock.anchor()
            start = anchor or datetime.now(UTC)
        self.directory.mkdir(mode=0o750, parents=True, exist_ok=True)
        name = f"session-{self.session_id:06d}-{start:%Y%m%dT%H%M%SZ}"
        if self.files:
            name += f"-part{len(self.files) + 1}"
        path = self.directory / f"{name}.ch10"
        writer = Chapter10Writer(path, channel_id=self.channel_id, start_time=start,
                                 tail=self.tail)
        self.files.append(path)
        log.info("recording to %s", path)
        return writer

    def flush(self) -> None:
        """Put what was recorded on disk (the open packet included)."""
        if self._writer is None or self.failed:
            return
        try:
            self._writer.flush()
        except OSError as error:
            self.failed = True
            log.error("recording stopped: %s", error)
            self._close_quietly()

    def close(self) -> None:
        """Close the file (idempotent)."""
        writer, self._writer = self._writer, None
        if writer is None:
            return
        try:
            writer.close()
        except OSError as error:
            log.error("closing the recording: %s", error)
        else:
            log.info("recorded %d messages to %s", self.messages, ", ".join(map(str,
                                                                                self.files)))

    def _close_quietly(self) -> None:
        writer, self._writer = self._writer, None
        if writer is not None:
            with contextlib.suppress(OSError, ValueError):
                writer.close()
