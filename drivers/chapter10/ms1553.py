"""MIL-STD-1553 Format 1 packets (data type 0x19) to :class:`MonitorRecord` messages.

Per message the packet stores an intra-packet time stamp (RTC counts), the block status word,
the gap word (GAP1 low byte, GAP2 high byte, 0.1 µs) and the words in bus order. This module
turns them into the record the live monitor produces:

* ``t_ns`` is the leading edge of the first command word's sync, as for live records. The
  channel-specific word (bits 31-30) says which bit the recorder stamped (0: the last bit
  of the last word, 1: the first bit of the first word, 2: the last bit of the command
  word); the message's length on the bus (20 µs a word, plus each response gap beyond the
  2 µs of contiguous words) moves the stamp to the start. ``end_ns`` is the end of the last word.
* bus, RT-RT and errors come from the block status word (:mod:`drivers.chapter10.status`);
  the words are split by :func:`drivers.chapter10.layout.split_message`.
* ``gaps_ns`` holds GAP1 (and GAP2 for RT-RT) for each status word present, in ns.
* ``extra`` holds the raw ``block_status``, the ``channel`` ID and, once a time packet has
  been read, the absolute ``time`` (:mod:`drivers.chapter10.timebase`) and, when the time
  packets give a full date, ``epoch_ns``: the record's ``t_ns`` as ns since 1970 UTC.
"""

from __future__ import annotations

import struct
from typing import Any

from drivers.chapter10.layout import split_message
from drivers.chapter10.status import (
    BUS_B,
    FORMAT_ERROR,
    INVALID_WORD_ERROR,
    MESSAGE_ERROR,
    RESPONSE_TIMEOUT,
    RT_TO_RT,
    SYNC_TYPE_ERROR,
    WORD_COUNT_ERROR,
    errors_for_words,
)
from drivers.chapter10.timebase import Timebase
from drivers.chapter10.walker import (
    HEADER_BYTES,
    SECONDARY_HEADER_BYTES,
    RawPacket,
    ReadIssue,
)
from drivers.mil1553.record import MonitorRecord
from drivers.mil1553.timing import CONTIGUOUS_GAP_NS, BusTiming
from drivers.mil1553.wordbatch import WORD_TIME_NS

TIME_TAG_LAST_BIT = 0
TIME_TAG_FIRST_BIT = 1
TIME_TAG_COMMAND_END = 2


def block_status_of(message: Any) -> int:
    """The block status word of a pychapter10 ``MS1553F1.Message`` (it splits the word
    into attributes; this puts it back together)."""
    return ((BUS_B if message.bus else 0) | (MESSAGE_ERROR if message.me else 0)
            | (RT_TO_RT if message.rt2rt else 0) | (FORMAT_ERROR if message.fe else 0)
            | (RESPONSE_TIMEOUT if message.timeout else 0)
            | (WORD_COUNT_ERROR if message.le else 0) | (SYNC_TYPE_ERROR if message.se else 0)
            | (INVALID_WORD_ERROR if message.we else 0))


def time_tag_bits(item: RawPacket) -> int:
    """Which bit the packet's message time stamps mark, from its channel-specific word
    (bits 31-30 as the standard and the sample recording have it; pychapter10 1.1.19 reads
    bits 25-24 and would say 0 for every packet of the sample)."""
    start = HEADER_BYTES + (SECONDARY_HEADER_BYTES if item.header.secondary_header else 0)
    return int.from_bytes(item.raw[start:start + 4], "little") >> 30


def message_span_ns(word_count: int, gaps_ns: tuple[int, ...]) -> int:
    """Time on the bus from the first sync's leading edge to the end of the last word."""
    idle = sum(max(0, gap - CONTIGUOUS_GAP_NS) for gap in gaps_ns)
    return word_count * WORD_TIME_NS + idle


def records_from_packet(item: RawPacket, timebase: Timebase,
                        timing: BusTiming | None = None
                        ) -> tuple[list[MonitorRecord], list[ReadIssue]]:
    """The records of one MS1553F1 packet, and the problems found in it (a message cut
    short or without words ends or skips with an issue; the rest of the packet is kept)."""
    header, packet = item.header, item.packet
    records: list[MonitorRecord] = []
    issues: list[ReadIssue] = []
    stamp_bit = time_tag_bits(item)
    packet_stamps = header.ipts_source != 0
    if packet_stamps:
        issues.append(ReadIssue(header.offset, "message time stamps in secondary-header format "
                                               "are not supported; the packet's time is used"))
    for number, message in enumerate(packet, start=1):
        if len(message.data) < message.length:
            issues.append(ReadIssue(header.offset, f"1553 message {number} cut short "
                                                   f"({len(message.data)} of {message.length} "
                                                   "bytes); rest of the packet skipped"))
            return records, issues
        if message.length < 2 or message.length % 2:
            issues.append(ReadIssue(header.offset, f"1553 message {number} has an impossible "
                                                   f"length of {message.length} bytes; skipped"))
            continue
        records.append(_record(message, header.channel_id,
                               header.rtc if packet_stamps else message.ipts, stamp_bit,
                               timebase, timing))
    if len(records) < packet.count and not issues:
        issues.append(ReadIssue(header.offset, f"1553 packet announces {packet.count} messages "
                                               f"but holds {len(records)}"))
    return records, issues


def _record(message: Any, channel: int, rtc: int, stamp_bit: int, timebase: Timebase,
            timing: BusTiming | None) -> MonitorRecord:
    raw = message.data
    words = struct.unpack(f"<{len(raw) // 2}H", raw)
    block_status = block_status_of(message)
    gap_word = message.gap_time
    gaps_all = ((gap_word & 0xFF) * 100, (gap_word >> 8) * 100)
    split = split_message(words, rt_to_rt=bool(block_status & RT_TO_RT),
                          timed_out=bool(block_status & RESPONSE_TIMEOUT),
                          gaps_ns=gaps_all, timing=timing)
    gaps = gaps_all[:len(split.status)]
    span = message_span_ns(len(words), gaps)
    stamp = timebase.ns(rtc)
    if stamp_bit == TIME_TAG_LAST_BIT:
        start = stamp - span
    elif stamp_bit == TIME_TAG_COMMAND_END:
        start = stamp - WORD_TIME_NS
    else:
        start = stamp
    errors = set(errors_for_words(block_status, expected_words=split.expected_words,
                                  stored_words=len(words))) | split.errors
    extra: dict[str, Any] = {"block_status": block_status, "channel": channel}
    absolute = timebase.absolute(rtc)
    if absolute is not None:
        extra["time"] = absolute
    epoch = timebase.epoch_ns(rtc)
    if epoch is not None:   # the record's start, as t_ns is
        extra["epoch_ns"] = epoch + (start - stamp)
    return MonitorRecord(
        t_ns=start, bus="B" if block_status & BUS_B else "A", format=split.format,
        command=split.command, data=split.data, status=split.status, gaps_ns=gaps,
        errors=tuple(sorted(errors)), command2=split.command2, end_ns=start + span,
        extra=extra)
