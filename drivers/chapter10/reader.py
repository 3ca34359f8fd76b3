"""Read a Chapter 10 file: 1553 records, ARINC 429 words and the problems met, in file order.

    reader = Chapter10Reader("flight.c10")
    for batch in reader:             # one batch per 1553 or ARINC 429 packet
        for record in batch.records:
            ...
    print(*reader.issues, sep="\\n")  # damaged packets skipped, with their file offsets

    for batch in reader.batches():   # consecutive 1553 packets merged, for speed
        batch.ms1553                 # an Ms1553Batch: arrays, no record objects

Time packets set the absolute time (:mod:`drivers.chapter10.timebase`); MS1553F1 packets
become an :class:`~drivers.chapter10.ms1553_batch.Ms1553Batch` (numpy, exactly the
:class:`~drivers.mil1553.record.MonitorRecord` values that :mod:`drivers.chapter10.ms1553`
builds one by one with ``batched=False``; ``batch.records`` builds them on demand);
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
from drivers.chapter10.ms1553_batch import Ms1553Batch, build_batch
from drivers.chapter10.ms1553_walk import new_parts, walk_packet
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


@dataclass(slots=True)
class Chapter10Batch:
    """What one data packet held (from :meth:`Chapter10Reader.batches`: one or more
    consecutive 1553 packets; ``offset`` and ``channel`` are then the first packet's)."""

    offset: int
    channel: int
    ms1553: Ms1553Batch | None = None
    arinc429: Arinc429Words | None = None
    _records: list[MonitorRecord] | None = None
    arinc429_at: list[tuple[int, Arinc429Words]] = field(default_factory=list)
    """From :meth:`Chapter10Reader.batches`: ARINC 429 packets met among the merged 1553
    packets, each with the number of ``ms1553`` messages that came before it in the file."""

    @property
    def records(self) -> list[MonitorRecord]:
        """The 1553 messages as records (built from :attr:`ms1553` on first use)."""
        if self._records is None:
            self._records = [] if self.ms1553 is None else self.ms1553.records()
        return self._records


class Chapter10Reader:
    """Iterate a Chapter 10 file as :class:`Chapter10Batch` items.

    ``channels``: the channel IDs to read (default: all); ``arinc429``: also decode ARINC
    429 packets; ``year``: the year of day-of-year time packets (for absolute time);
    ``timing``: the response-time limits replayed gaps are judged by; ``batched=False``:
    build each record from pychapter10's parse, one by one (the reference path, slower).
    """

    def __init__(self, path: str | Path, *, channels: Collection[int] | None = None,
                 arinc429: bool = True, year: int | None = None,
                 timing: BusTiming | None = None, batched: bool = True,
                 name: str | None = None) -> None:
        types = {TIME_F1, MS1553_F1} | ({ARINC429_F0} if arinc429 else set())
        self.batched = batched
        self.walker = PacketWalker(path, frozenset(types),
                                   frozenset({MS1553_F1}) if batched else frozenset(), name)
        self.path = self.walker.path
        self.name = self.walker.name
        """What messages call the input: the path, or ``stdin`` for a spooled stream."""
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
        """One batch per 1553 or ARINC 429 packet."""
        return self._batches(merge=0)

    def batches(self, max_messages: int = 8192) -> Iterator[Chapter10Batch]:
        """Like iterating, but consecutive 1553 packets are merged into one batch of up to
        about ``max_messages`` messages; ARINC 429 packets between them come in the batch's
        ``arinc429_at`` with their place among its messages; each message keeps the time
        reference in force when its packet was read."""
        return self._batches(merge=max(1, max_messages))

    def _batches(self, merge: int) -> Iterator[Chapter10Batch]:
        parts = new_parts()
        first: tuple[int, int] | None = None
        held = 0

        between: list[tuple[int, Arinc429Words]] = []

        def flush() -> Chapter10Batch | None:
            nonlocal parts, first, held, between
            batch = build_batch(parts, self.timebase, self.timing)
            out = None if first is None else Chapter10Batch(first[0], first[1], ms1553=batch,
                                                            arinc429_at=between)
            parts, first, held, between = new_parts(), None, 0, []
            return out

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
                if item.packet is not None:   # parsed by pychapter10: the per-message path
                    records, issues = records_from_packet(item, self.timebase, self.timing)
                    self._message_issues += issues
                    if first is not None:
                        done = flush()
                        if done is not None:
                            yield done
                    yield Chapter10Batch(header.offset, header.channel_id, _records=records)
                    continue
                if first is None:
                    first = (header.offset, header.channel_id)
                held += walk_packet(item, parts, self._message_issues, self.timebase)
                if held >= merge:
                    done = flush()
                    if done is not None:
                        yield done
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
                if first is not None and merge > 0:
                    between.append((held, words))
                    continue
                if first is not None:
                    done = flush()
                    if done is not None:
                        yield done
                yield Chapter10Batch(header.offset, header.channel_id, arinc429=words)
        if first is not None:
            done = flush()
            if done is not None:
                yield done
        if self.walker.headers_seen == 0:
            raise CaptureFormatError(f"{self.name}: not a Chapter 10 file (no valid packet "
                                     "header found)")
