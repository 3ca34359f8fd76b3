"""Record monitor records as an IRIG 106 Chapter 10 file: :class:`Chapter10Writer`.

    with Chapter10Writer("flight.c10") as writer:
        writer.write(records)

The file holds, in this order: the TMATS setup record (channel 0), a time packet for the
start, then MIL-STD-1553 Format 1 packets on ``channel_id`` with a time packet (channel
``channel_id + 1``) at every whole second of recorded time. Record time tags (ns from capture
start) become the 10 MHz relative time counter, count 0 at the start; the time packets tie the
counter to the wall clock at the start (or ``start_time``), truncated to the 10 ms the time
packet format resolves.

A 1553 packet is closed, and written to the operating system at once, when its first message
is 100 ms of recorded time older than the next record, when it would pass 64 KiB, before each
time packet, and on :meth:`~Chapter10Writer.flush` / :meth:`~Chapter10Writer.close`. A crash of
the process therefore loses at most the open packet (100 ms of traffic, 64 KiB); ``flush``
also asks the OS to put the file on disk (fsync), bounding what a power loss takes.
"""

from __future__ import annotations

import os
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from importlib.metadata import PackageNotFoundError, version
from types import TracebackType

from drivers.chapter10.recording_packets import (
    IPH_BYTES,
    RTC_HZ,
    RTC_NS,
    TMATS_CHANNEL,
    ms1553_packet,
    time_packet,
    tmats_packet,
)
from drivers.chapter10.tmats import TMATS_VERSION, RecordingSetup, tmats_text
from drivers.mil1553.record import MonitorRecord

MAX_PACKET_NS = 100_000_000
"""A 1553 packet spans at most this much recorded time (IRIG 106's 100 ms packet rule)."""
MAX_PACKET_BYTES = 65_536
"""A 1553 packet's messages take at most this many bytes (the standard allows 512 KiB)."""
MAX_TIME_FILL_S = 3_600
"""After a silence longer than this, only the time packet of the second the traffic resumes
in is written, not one per silent second."""
TIME_RESOLUTION_US = 10_000
"""Time Data Format 1 resolves 10 ms."""
LAST_TIME = datetime(3999, 12, 31, 23, 59, 59)
"""The last second a time packet can give (its year's thousands digit has two bits)."""
FILE_MODE = 0o640
"""A new recording's mode: the process umask can only make it stricter (a daemon started
outside systemd's ``UMask=0027`` would otherwise write fault data every local user can read)."""


@dataclass(frozen=True, slots=True)
class RecordingStats:
    """What a writer has put in its file so far."""

    messages: int
    """1553 messages written."""
    error_messages: int
    """Messages among them with at least one error."""
    packets: int
    """Chapter 10 packets of every kind (TMATS, time, 1553)."""
    bytes: int
    """File size in bytes."""
    skipped: int = 0
    """Records left out because the file cannot say when they happened (a time tag past
    the last date a time packet can hold, the year 3999); the others are written."""


class Chapter10Writer:
    """Writes MonitorRecords to an IRIG 106 Chapter 10 file (see the module docstring).

    ``channel_id`` (1-65534) is the 1553 channel; time packets use ``channel_id + 1``.
    ``start_time`` is the absolute time of time tag 0 (default: the wall clock now, UTC; a
    naive datetime is taken as UTC). The file is created (mode :data:`FILE_MODE`) or truncated
    at once. One thread
    at a time may use a writer.
    """

    def __init__(self, path: str | os.PathLike[str], *, channel_id: int = 1,
                 start_time: datetime | None = None, tail: str = "") -> None:
        if not 1 <= channel_id <= 0xFFFE:
            raise ValueError(f"channel_id must be 1-65534, not {channel_id}")
        start = _time_packet_instant(start_time or datetime.now(UTC))
        setup = RecordingSetup(bus_channel_id=channel_id, time_channel_id=channel_id + 1,
                               created=start, recorder_version=_recorder_version(), tail=tail)
        tmats = tmats_text(setup)   # a tail holding a TMATS separator fails before the file
        self.path = os.fspath(path)
        self.channel_id = channel_id
        self.time_channel_id = channel_id + 1
        self.start_time = start
        # created FILE_MODE whatever the umask (it can only make the file stricter)
        fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, FILE_MODE)
        self._file = os.fdopen(fd, "wb")
        self._sequence: Counter[int] = Counter()
        self._pending: list[MonitorRecord] = []
        self._pending_bytes = 0
        self._pending_first = 0
        self._next_second = 0
        self._messages = 0
        self._error_messages = 0
        self._packets = 0
        self._bytes = 0
        self._closed = False
        self._skipped = 0
        self._last_second = (LAST_TIME - self.start_time) // timedelta(seconds=1)
        self._put(tmats_packet(self._next_sequence(TMATS_CHANNEL), tmats, TMATS_VERSION))
        self._time_packets_through(0)
        self._file.flush()

    # --- the API ----------------------------------------------------------------------------
    def write(self, records: Iterable[MonitorRecord]) -> None:
        """Add records (in time order; one out of order is written where it comes). A record
        whose time cannot be written is counted in :attr:`stats` ``.skipped``, not raised:
        the records after it are still written."""
        if self._closed:
            raise ValueError(f"{self.path}: write to a closed Chapter 10 writer")
        for record in records:
            counts = (record.t_ns + RTC_NS // 2) // RTC_NS
            if counts // RTC_HZ > self._last_second:
                self._skipped += 1   # one wild time tag must not stop the recording
                continue
            self._time_packets_through(counts)
            size = IPH_BYTES + 2 * _word_count(record)
            if self._pending and (counts - self._pending_first >= MAX_PACKET_NS // RTC_NS
                                  or self._pending_bytes + size > MAX_PACKET_BYTES):
                self._write_pending()
            if not self._pending:
                self._pending_first = counts
            self._pending.append(record)
            self._pending_bytes += size
            self._messages += 1
            self._error_messages += bool(record.errors)

    def flush(self) -> None:
        """Write the open packet, and put the file on disk (fsync)."""
        if self._closed:
            return
        self._write_pending()
        self._file.flush()
        os.fsync(self._file.fileno())

    def close(self) -> None:
        """Write everything still held and close the file (idempotent)."""
        if self._closed:
            return
        try:
            self.flush()
        finally:
            self._closed = True
            self._file.close()

    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def stats(self) -> RecordingStats:
        """Messages, messages with errors, packets and bytes written so far (messages held in
        the open packet count as messages, not yet as bytes)."""
        return RecordingStats(self._messages, self._error_messages, self._packets, self._bytes,
                              self._skipped)

    def __enter__(self) -> Chapter10Writer:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        self.close()

    # --- packets ----------------------------------------------------------------------------
    def _time_packets_through(self, counts: int) -> None:
        """Write the time packets of every whole second up to ``counts`` not yet written."""
        last = counts // RTC_HZ
        if last < self._next_second:
            return
        self._write_pending()
        first = self._next_second if last - self._next_second <= MAX_TIME_FILL_S else last
        for second in range(first, last + 1):
            when = self.start_time + timedelta(seconds=second)
            self._put(time_packet(self.time_channel_id, self._next_sequence(self.time_channel_id),
                                  second * RTC_HZ, when))
        self._next_second = last + 1

    def _write_pending(self) -> None:
        if not self._pending:
            return
        records, self._pending, self._pending_bytes = self._pending, [], 0
        self._put(ms1553_packet(self.channel_id, self._next_sequence(self.channel_id), records))
        self._file.flush()

    def _next_sequence(self, channel: int) -> int:
        """The channel's packet sequence number (0-255, wrapping), counted per channel."""
        sequence = self._sequence[channel] & 0xFF
        self._sequence[channel] += 1
        return sequence

    def _put(self, raw: bytes) -> None:
        self._file.write(raw)
        self._packets += 1
        self._bytes += len(raw)


def _recorder_version() -> str:
    """The installed MAPR version, for the TMATS recorder model (empty when not installed)."""
    try:
        return f"MAPR {version('mapr')}"
    except PackageNotFoundError:
        return ""


def _word_count(record: MonitorRecord) -> int:
    return (record.command is not None) + (record.command2 is not None) + len(record.data) \
        + len(record.status)


def _time_packet_instant(when: datetime) -> datetime:
    """``when`` in UTC without a zone, truncated to the time packet's 10 ms."""
    if when.tzinfo is not None:
        when = when.astimezone(UTC).replace(tzinfo=None)
    return when.replace(microsecond=when.microsecond // TIME_RESOLUTION_US * TIME_RESOLUTION_US)
