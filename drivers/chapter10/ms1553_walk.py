"""The walk of MS1553F1 packet bodies: where each message sits, then its fields as arrays.

A 1553 packet body is a chain of messages, each a 14-byte intra-packet header (time stamp,
block status, gap times, length in bytes) and its words. Where message ``m + 1`` starts
depends on message ``m``'s length, so that part is sequential: :func:`walk_packet` follows
the chain with a tight Python loop over a 16-bit view of the body, one list append per
message (messages start on even offsets, so each length is one element of that view). The
problems (a message cut short, an impossible length, fewer messages than announced) are
found there, packet by packet, as pychapter10 reads them. Everything else (time stamps,
block status, gap words, the words themselves) is gathered with numpy by :func:`gather`,
once for all the packets of a batch.

This path needs numpy only: a command that reads a Chapter 10 file starts without
importing a compiler. The compiled walk it replaced was barely faster, and loading it cost
every process more CPU than it saved (docs/chapter10.md and docs/figures.md have the
figures).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from drivers.chapter10.timebase import Timebase, TimeReference
from drivers.chapter10.walker import HEADER_BYTES, SECONDARY_HEADER_BYTES, RawPacket, ReadIssue

I64 = npt.NDArray[np.int64]
U16 = npt.NDArray[np.uint16]

IPH_BYTES = 14
"""Intra-packet header of one message: 6-byte time stamp, 2 reserved, block status, gap
times, length."""
BLOCK_STATUS_BITS = 0x3E38
"""The block status bits pychapter10 reads (and the per-message path keeps)."""


@dataclass
class Parts:
    """What :func:`walk_packet` gathered from consecutive packets, for :func:`gather`.

    Per packet: its body bytes, its messages' header offsets (in the concatenated bodies)
    and how many it kept, and the packet's constants (its RTC when its messages take the
    packet's time, else -1; time-tag bits; channel; file offset; time reference)."""

    bodies: list[npt.NDArray[np.uint8]] = field(default_factory=list)
    at: list[I64] = field(default_factory=list)
    kept: list[int] = field(default_factory=list)
    packet_rtc: list[int] = field(default_factory=list)
    stamp_bit: list[int] = field(default_factory=list)
    channel: list[int] = field(default_factory=list)
    offset: list[int] = field(default_factory=list)
    ref_id: list[int] = field(default_factory=list)
    refs: list[TimeReference | None] = field(default_factory=list)
    byte_total: int = 0


def new_parts() -> Parts:
    return Parts()


def _chain(heads: memoryview, size: int, count: int) -> list[int]:
    """Offsets, in 16-bit words, of the intra-packet headers of one body (``heads``: its
    16-bit words, ``size`` its length in bytes), as pychapter10 follows them: at most
    ``count``, while a whole header fits; the last one's message may run past the end (cut
    short). A header is 7 words; the message after it takes ``ceil(length / 2)``."""
    starts: list[int] = []
    append = starts.append
    at = 0
    last = (size - IPH_BYTES) >> 1
    while at <= last:   # no count check per step: at most size / 14 steps, cut to count
        append(at)
        n = heads[at + 6]
        at += 7 + ((n + 1) >> 1)
    return starts[:count] if len(starts) > count else starts


def walk_packet(item: RawPacket, parts: Parts, found: list[ReadIssue], timebase: Timebase
                ) -> int:
    """Add one packet's messages to ``parts`` and its problems to ``found`` (the same
    problems, in the same words, as :func:`~drivers.chapter10.ms1553.records_from_packet`).
    Returns the number of messages added."""
    header = item.header
    start = HEADER_BYTES + (SECONDARY_HEADER_BYTES if header.secondary_header else 0)
    csdw = int.from_bytes(item.raw[start:start + 4], "little")
    count = csdw & 0xFFFFFF
    held = header.data_length - 4
    if item.cut:   # only the bytes before the cut, an even number (messages are 16-bit)
        held = max(0, min(held, len(item.raw) - start - 4)) & ~1
    body = np.frombuffer(item.raw, np.uint8, held, start + 4)
    size = body.size
    half = np.frombuffer(item.raw, "<u2", size // 2, start + 4).astype(np.uint16, copy=False)
    at = np.asarray(_chain(half.data, size, count), np.int64)
    length = half[at + 6].astype(np.int64)
    at <<= 1
    cut = np.zeros(at.size, np.bool_)
    if at.size:
        cut[-1] = at[-1] + IPH_BYTES + length[-1] > size
    bad = ~cut & ((length < 2) | (length & 1 != 0))
    issues: list[ReadIssue] = []
    packet_stamps = header.ipts_source != 0
    if packet_stamps:
        issues.append(ReadIssue(header.offset, "message time stamps in secondary-header format "
                                               "are not supported; the packet's time is used"))
    for number in np.flatnonzero(cut | bad).tolist():
        n_bytes = int(length[number])
        if cut[number] and item.cut:
            continue   # the packet's cut, reported once below
        if cut[number]:
            held = size - int(at[number]) - IPH_BYTES
            issues.append(ReadIssue(header.offset, f"1553 message {number + 1} cut short "
                                                   f"({held} of {n_bytes} "
                                                   "bytes); rest of the packet skipped"))
        else:
            issues.append(ReadIssue(header.offset, f"1553 message {number + 1} has an "
                                                   f"impossible length of {n_bytes} bytes; "
                                                   "skipped"))
    keep = ~(cut | bad)
    kept = int(np.count_nonzero(keep))
    if item.cut:
        issues.append(ReadIssue(header.offset, f"{item.cut}: the {kept} whole 1553 messages "
                                               f"before the cut read, {count - kept} of the "
                                               f"{count} it announces lost"))
    elif kept < count and not issues and not (at.size and cut[-1]):
        issues.append(ReadIssue(header.offset, f"1553 packet announces {count} messages "
                                               f"but holds {kept}"))
    found += issues
    if not kept:
        return 0
    parts.bodies.append(body)
    parts.at.append((at if kept == at.size else at[keep]) + parts.byte_total)
    parts.kept.append(kept)
    parts.packet_rtc.append(header.rtc if packet_stamps else -1)
    parts.stamp_bit.append(csdw >> 30)
    parts.channel.append(header.channel_id)
    parts.offset.append(header.offset)
    if not parts.refs or parts.refs[-1] is not timebase.reference:
        parts.refs.append(timebase.reference)
    parts.ref_id.append(len(parts.refs) - 1)
    parts.byte_total += size
    return kept


@dataclass(frozen=True, slots=True)
class Walked:
    """The messages of :class:`Parts` as arrays: 48-bit time stamp (the packet's RTC for
    packets whose messages take it), block status (pychapter10's bits), gap word, word
    count, where the message's words start in ``words``, and the per-packet constants
    spread over the messages."""

    rtc: I64
    block: I64
    gap: I64
    first: I64
    n_words: I64
    words: U16
    stamp_bit: I64
    channel: I64
    offset: I64
    ref_id: I64


def gather(parts: Parts) -> Walked:
    """Read every kept message's fields out of the concatenated bodies at once."""
    data = np.concatenate(parts.bodies) if len(parts.bodies) > 1 else parts.bodies[0]
    at = np.concatenate(parts.at)
    kept = np.asarray(parts.kept, np.int64)

    def le16(where: I64) -> I64:
        return data[where].astype(np.int64) | data[where + 1].astype(np.int64) << 8

    stamp = le16(at) | le16(at + 2) << 16 | le16(at + 4) << 32
    packet_rtc = np.repeat(np.asarray(parts.packet_rtc, np.int64), kept)
    rtc = np.where(packet_rtc >= 0, packet_rtc, stamp)
    n_words = le16(at + 12) >> 1
    first = np.cumsum(n_words) - n_words
    total = int(n_words.sum())
    word_at = (np.repeat(at + IPH_BYTES - 2 * first, n_words)
               + 2 * np.arange(total, dtype=np.int64))
    words = (data[word_at].astype(np.uint16) | data[word_at + 1].astype(np.uint16) << 8)

    def spread(values: list[int]) -> I64:
        return np.repeat(np.asarray(values, np.int64), kept)

    return Walked(rtc=rtc, block=le16(at + 8) & BLOCK_STATUS_BITS, gap=le16(at + 10),
                  first=first, n_words=n_words, words=words.astype(np.uint16, copy=False),
                  stamp_bit=spread(parts.stamp_bit), channel=spread(parts.channel),
                  offset=spread(parts.offset), ref_id=spread(parts.ref_id))
