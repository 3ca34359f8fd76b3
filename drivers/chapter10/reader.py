"""Read a Chapter 10 file: 1553 records, ARINC 429 words and the problems met, in file order.

    reader = Chapter10Reader("flight.c10")
    for batch in reader:             # one batch per 1553 or ARINC 429 packet
        for record in batch.records:
            ...
    print(*reader.issues, sep="\\n")  # damaged packets skipped, with their file offsets

Time packets set the absolute time (:mod:`drivers.chapter10.timebase`); MS1553F1 packets
become :class:`~drivers.mil1553.record.MonitorRecord` (:mod:`drivers.chapter10.ms1553`);
ARINC 429 packets become :class:`~drivers.chapter10.arinc429.Arinc429Words`. Packets come in
file order, which is per-channel time order; packets of different channels may overlap in
time, so records of different channels are not merged into one time order.
"""

from __future__ import annotations

from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from drivers.chapter10.arinc429 import Arinc429Words, words_from_packet
from drivers.chapter10.ms1553 import records_from_packet
from drivers.chapter10.timebase import Timebase
from drivers.chapter10.walker import (
    ARINC429_F0,
    HEADER_BYTES,
    MS1553_F1,
    SECONDARY_HEADER_BYTES,
    TIME_F1,
    PacketWalker,
    ReadIssue,
)
from drivers.errors import CaptureFormatError
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.timing import BusTiming


@dataclass(frozen=True, slots=True)
class Chapter10Batch:
    """What one data packet held."""

    offset: int
    channel: int
    records: list[MonitorRecord] = field(default_factory=list)
    arinc429: Arinc429Words | None = None


class Chapter10Reader:
    """Iterate a Chapter 10 file as :class:`Chapter10Batch` items.

    ``channels``: the channel IDs to read (default: all); ``arinc429``: also decode ARINC
    429 packets; ``year``: the year of day-of-year time packets (for absolute time);
    ``timing``: the response-time limits replayed gaps are judged by.
    """

    def __init__(self, path: str | Path, *, channels: Collection[int] | None = None,
                 arinc429: bool = True, year: int | None = None,
                 timing: BusTiming | None = None) -> None:
        types = {TIME_F1, MS1553_F1} | ({ARINC429_F0} if arinc429 else set())
        self.walker = PacketWalker(path, frozenset(types))
        self.path = self.walker.path
        self.channels = None if channels is None else frozenset(channels)
        self.timebase = Timebase(year)
        self.timing = timing
        self._message_issues: list[ReadIssue] = []
        self.channels_seen: set[int] = set()
        """1553 channel IDs met so far (read or not)."""
        self.arinc429_channels_seen: set[int] = set()
        """ARINC 429 channel IDs met so far (read or not)."""

    @property
    def issues(self) -> list[ReadIssue]:
        """Damaged or unreadable parts of the file met so far, in file order."""
        return sorted([*self.walker.issues, *self._message_issues], key=lambda i: i.offset)

    @property
    def position(self) -> int:
        """Bytes of the file walked so far."""
        return self.walker.position

    @property
    def size(self) -> int:
        return self.walker.size

    def close(self) -> None:
        self.walker.close()

    def __iter__(self) -> Iterator[Chapter10Batch]:
        for item in self.walker:
            header = item.header
            if self.walker.first_rtc is not None:
                self.timebase.start(self.walker.first_rtc)
            if header.data_type == TIME_F1:
                try:
                    self.timebase.add_time_packet(item.packet, header.rtc)
                except (ValueError, OverflowError) as error:  # a date that does not exist
                    self._message_issues.append(ReadIssue(
                        header.offset, f"time packet gives no valid time ({error}); skipped"))
                continue
            if header.data_type == MS1553_F1:
                self.channels_seen.add(header.channel_id)
            elif header.data_type == ARINC429_F0:
                self.arinc429_channels_seen.add(header.channel_id)
            if self.channels is not None and header.channel_id not in self.channels:
                continue
            if header.data_type == MS1553_F1:
                records, issues = records_from_packet(item, self.timebase, self.timing)
                self._message_issues += issues
                yield Chapter10Batch(header.offset, header.channel_id, records=records)
            elif header.data_type == ARINC429_F0:
                start = HEADER_BYTES + (SECONDARY_HEADER_BYTES if header.secondary_header
                                        else 0)
                body = item.raw[start + 4:start + header.data_length]
                words = words_from_packet(body, item.packet.count, header.channel_id,
                                          self.timebase.ns(header.rtc))
                if len(words) < item.packet.count:
                    self._message_issues.append(ReadIssue(
                        header.offset, f"ARINC 429 packet announces {item.packet.count} words "
                                       f"but holds {len(words)}"))
                yield Chapter10Batch(header.offset, header.channel_id, arinc429=words)
        if self.walker.headers_seen == 0:
            raise CaptureFormatError(f"{self.path}: not a Chapter 10 file (no valid packet "
                                     "header found)")
