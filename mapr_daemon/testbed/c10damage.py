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
    "channel_id": (2, "<H"),
    "packet_length": (4, "<I"),
    "data_length": (8, "<I"),
    "header_version": (12, "<B"),
    "sequence_number": (13, "<B"),
    "flags": (14, "<B"),
    "data_type": (15, "<B"),
    "rtc_low": (16, "<I"),
}
"""Primary header fields a damage may rewrite: byte offset in the header, struct format."""

KINDS = ("field", "flip", "zeros", "truncate")


@dataclass(frozen=True, slots=True)
class PacketSpan:
    """Where one packet of the undamaged file lies, and its data type."""

    offset: int
    length: int
    data_type: int


@dataclass(frozen=True, slots=True)
class Damage:
    """One change to a file: ``kind`` is ``field`` (``field`` of the packet at ``offset``
    set to ``value``, header checksum recomputed), ``flip`` (byte at ``offset`` xor
    ``value``), ``zeros`` (``value`` bytes from ``offset`` zeroed) or ``truncate`` (the file
    cut at ``offset``)."""

    kind: str
    offset: int
    value: int
    field: str = ""

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
            header = bytes(out[self.offset:self.offset + 22])
            struct.pack_into("<H", out, self.offset + 22, sum(array("H", header)) & 0xFFFF)
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
        return self.offset, self.offset + HEADER_BYTES


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


def random_damage(data: bytes, spans: list[PacketSpan], rng: random.Random) -> Damage:
    """One damage of a random kind; header-field damages pick a field and a value that is
    often a boundary (0, 1-3, a small or an off-by-some length, all ones)."""
    kind = rng.choice(KINDS)
    if kind == "field":
        span = rng.choice(spans)
        name = rng.choice(sorted(FIELDS))
        where, fmt = FIELDS[name]
        (old,) = struct.unpack_from(fmt, data, span.offset + where)
        top = (1 << 8 * struct.calcsize(fmt)) - 1
        value = rng.choice([0, 1, 2, 3, 4, 5, 7, 24, 36, top, old + rng.randint(-8, 8),
                            old ^ 1 << rng.randrange(8 * struct.calcsize(fmt)),
                            rng.randint(0, top)])
        return Damage("field", span.offset, value % (top + 1), name)
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
