"""Damage a Chapter 10 recording on purpose, and say which of its packets were left intact.

The reader's promise (docs/chapter10.md, "Damaged files") is that a damaged packet is
reported and skipped and every other packet is still read. To test that promise, a
:class:`Damage` is applied to a recording's bytes: header fields rewritten with the header
checksum made valid again (so the walker cannot reject the header on its checksum alone),
bytes flipped, runs zeroed, or the file cut. :func:`intact_packets` then names the packets no
damage touched: those whose messages must still come out.

This is test equipment (like the rest of :mod:`mapr_daemon.testbed`): production code never
imports it.
"""

from __future__ import annotations

import random
import struct
from array import array
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

from drivers.chapter10.writer import Chapter10Writer
from drivers.mil1553.record import MonitorRecord, TransferFormat
from drivers.mil1553.words import CommandWord, StatusWord

HEADER_BYTES = 24

FIELDS: dict[str, tuple[int, str]] = {
    "sync": (0, "<H"),
    "channel_id": (2, "<H"),
    "packet_length": (4, "<I"),
    "data_length": (8, "<I"),
    "header_version": (12, "<B"),
    "sequence_number": (13, "<B"),
    "flags": (14, "<B"),
    "data_type": (15, "<B"),
    "rtc_low": (16, "<I"),
    "rtc_high": (20, "<H"),
    "checksum": (22, "<H"),
}
"""Primary header fields a damage may rewrite: byte offset in the header, struct format
(every field of the header; the checksum is recomputed after any other field)."""

BODY_FIELDS: dict[str, str] = {
    "csdw": "<I",
    "ipts": "<Q",
    "block_status": "<H",
    "gap_time": "<H",
    "message_length": "<H",
}
"""Fields of a 1553 packet's body a ``body`` damage may rewrite: the channel-specific word
(message count, time-tag bits) and, per message, its intra-packet header (time stamp, block
status, gap times, length)."""

KINDS = ("field", "body", "flip", "zeros", "truncate")


@dataclass(frozen=True, slots=True)
class PacketSpan:
    """Where one packet of the undamaged file lies, and its data type."""

    offset: int
    length: int
    data_type: int


@dataclass(frozen=True, slots=True)
class Damage:
    """One change to a file: ``kind`` is ``field`` (``field`` of the packet at ``offset``
    set to ``value``, header checksum recomputed unless the field is the checksum), ``body``
    (the body field ``field`` at byte ``offset`` of the file set to ``value``, in the packet
    at ``packet``, whose data checksum is recomputed), ``flip``
    (byte at ``offset`` xor ``value``), ``zeros`` (``value`` bytes from ``offset`` zeroed)
    or ``truncate`` (the file cut at ``offset``)."""

    kind: str
    offset: int
    value: int
    field: str = ""
    packet: int = -1

    def apply(self, data: bytes) -> bytes:
        out = bytearray(data)
        if self.kind == "truncate":
            return bytes(out[:self.offset])
        if self.kind == "flip":
            out[self.offset] ^= self.value
        elif self.kind == "zeros":
            out[self.offset:self.offset + self.value] = bytes(
                len(out[self.offset:self.offset + self.value]))
        elif self.kind == "field":
            where, fmt = FIELDS[self.field]
            struct.pack_into(fmt, out, self.offset + where,
                             self.value & (1 << 8 * struct.calcsize(fmt)) - 1)
            if self.field != "checksum":
                header = bytes(out[self.offset:self.offset + 22])
                struct.pack_into("<H", out, self.offset + 22, sum(array("H", header)) & 0xFFFF)
        elif self.kind == "body":
            fmt = BODY_FIELDS[self.field]
            struct.pack_into(fmt, out, self.offset,
                             self.value & (1 << 8 * struct.calcsize(fmt)) - 1)
            _fix_data_checksum(out, self.packet)
        else:
            raise ValueError(f"unknown damage kind {self.kind!r}")
        return bytes(out)

    def touched(self) -> tuple[int, int]:
        """The byte range ``[start, end)`` this damage changed (to the end for a cut)."""
        if self.kind == "truncate":
            return self.offset, 1 << 62
        if self.kind == "flip":
            return self.offset, self.offset + 1
        if self.kind == "zeros":
            return self.offset, self.offset + self.value
        if self.kind == "body":
            return self.offset, self.offset + struct.calcsize(BODY_FIELDS[self.field])
        return self.offset, self.offset + HEADER_BYTES


def _fix_data_checksum(out: bytearray, packet: int) -> None:
    """Recompute the data checksum of the packet at ``packet`` (8, 16 or 32 bits over the
    body after the headers, as the flags say; none: nothing to do)."""
    (length,) = struct.unpack_from("<I", out, packet + 4)
    flags = out[packet + 14]
    kind = flags & 3
    size = (0, 1, 2, 4)[kind]
    if not size:
        return
    start = packet + HEADER_BYTES + (SECONDARY_HEADER_BYTES if flags & 0x80 else 0)
    end = packet + length - size
    body = bytes(out[start:end])
    body = body[:len(body) - len(body) % size]
    total = sum(array("xBHI"[kind], body)) & (1 << 8 * size) - 1
    out[end:end + size] = total.to_bytes(size, "little")


def packet_spans(data: bytes) -> list[PacketSpan]:
    """The packets of an undamaged file, in order (walking the packet lengths; a cut last
    packet is left out)."""
    spans = []
    pos = 0
    while pos + HEADER_BYTES <= len(data):
        sync, length = struct.unpack_from("<HxxI", data, pos)
        if sync != 0xEB25 or length < HEADER_BYTES or pos + length > len(data):
            break
        spans.append(PacketSpan(pos, length, data[pos + 15]))
        pos += length
    return spans


MS1553_TYPE = 0x19
SECONDARY_HEADER_BYTES = 12
_MESSAGE_HEADER = {"ipts": 0, "block_status": 8, "gap_time": 10, "message_length": 12}


def body_fields(data: bytes, span: PacketSpan) -> list[tuple[str, int]]:
    """(field, byte offset in the file) of every body field of a 1553 packet: its
    channel-specific word, then each message's intra-packet header, walking the stored
    message lengths."""
    if span.data_type != MS1553_TYPE:
        return []
    start = span.offset + HEADER_BYTES
    if data[span.offset + 14] & 0x80:
        start += SECONDARY_HEADER_BYTES
    (data_length,) = struct.unpack_from("<I", data, span.offset + 8)
    end = min(start + data_length, span.offset + span.length)
    found = [("csdw", start)]
    pos = start + 4
    while pos + 14 <= end:
        found += [(name, pos + where) for name, where in _MESSAGE_HEADER.items()]
        (length,) = struct.unpack_from("<H", data, pos + 12)
        pos += 14 + length
    return found


def _boundary_value(rng: random.Random, old: int, fmt: str) -> int:
    """A value that is often a boundary (0, 1-3, a small or an off-by-some length, all
    ones, one bit flipped), else any value the field can hold."""
    top = (1 << 8 * struct.calcsize(fmt)) - 1
    value = rng.choice([0, 1, 2, 3, 4, 5, 7, 24, 36, top, old + rng.randint(-8, 8),
                        old ^ 1 << rng.randrange(8 * struct.calcsize(fmt)),
                        rng.randint(0, top)])
    return value % (top + 1)


def random_damage(data: bytes, spans: list[PacketSpan], rng: random.Random) -> Damage:
    """One damage of a random kind; field damages (header or 1553 body) pick a field and a
    value that is often a boundary."""
    kind = rng.choice(KINDS)
    if kind == "body":
        candidates = [s for s in spans if s.data_type == MS1553_TYPE]
        if candidates:
            span = rng.choice(candidates)
            name, offset = rng.choice(body_fields(data, span))
            (old,) = struct.unpack_from(BODY_FIELDS[name], data, offset)
            return Damage("body", offset, _boundary_value(rng, old, BODY_FIELDS[name]), name,
                          span.offset)
        kind = "field"
    if kind == "field":
        span = rng.choice(spans)
        name = rng.choice(sorted(FIELDS))
        where, fmt = FIELDS[name]
        (old,) = struct.unpack_from(fmt, data, span.offset + where)
        return Damage("field", span.offset, _boundary_value(rng, old, fmt), name)
    if kind == "flip":
        return Damage("flip", rng.randrange(len(data)), 1 << rng.randrange(8))
    if kind == "zeros":
        return Damage("zeros", rng.randrange(len(data)), rng.randint(1, 64))
    return Damage("truncate", rng.randrange(len(data)), 0)


def intact_packets(spans: list[PacketSpan], damage: Damage) -> list[PacketSpan]:
    """The packets no byte of ``damage`` touched."""
    start, end = damage.touched()
    return [s for s in spans if s.offset + s.length <= start or s.offset >= end]


def many_packet_recording(path: Path, messages: int = 150) -> None:
    """A recording of BC-RT and RT-BC messages (3 RTs, both buses, 3 s: about 30 packets of
    1553 messages and a time packet a second), from the project's own writer."""
    records = []
    for i in range(messages):
        tx = bool(i % 2)
        count = 1 + i % 32
        command = CommandWord(5 + i % 3, tx, 1 + i % 30, count % 32).value
        fmt = TransferFormat.RT_BC if tx else TransferFormat.BC_RT
        records.append(MonitorRecord(i * 20_000_000, "AB"[i % 2], fmt, command,
                                     data=tuple((i * 7 + k) & 0xFFFF for k in range(count)),
                                     status=(StatusWord(5 + i % 3).value,),
                                     gaps_ns=(6_000,)))
    with Chapter10Writer(path, start_time=datetime(2025, 1, 1, 12)) as writer:
        writer.write(records)
