"""Walk a Chapter 10 file packet by packet, reporting and skipping what is damaged.

pychapter10 parses each packet (:mod:`chapter10`). Its own file iterator is not used because
on damaged input it resynchronizes silently one byte at a time, ends a truncated file without
a word, never checks the data checksum and stops with ``NotImplementedError`` on a data type
it does not know. Here every packet is framed first: sync pattern 0xEB25, header checksum,
lengths, data checksum. A damaged packet becomes a :class:`ReadIssue` naming its file offset;
the walk then looks for the next valid header and goes on, so one bad packet loses only itself.

A packet of a type the walk is not asked for is passed over by its length, unread (video and
PCM make most of a recording's bytes): the valid header after it proves that length; when
the bytes there are no header, the packet is read and checked after all, as any other, so a
cut packet still gives up what follows it. Only a damaged data checksum in a packet nobody
reads goes unreported.
"""

from __future__ import annotations

import os
import struct
from array import array
from collections.abc import Iterator
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from chapter10.c10 import TYPES

from drivers.errors import CaptureFormatError

SYNC_PATTERN = 0xEB25
SYNC_BYTES = struct.pack("<H", SYNC_PATTERN)
HEADER_BYTES = 24
SECONDARY_HEADER_BYTES = 12
MAX_PACKET_BYTES = 524_288 + HEADER_BYTES + SECONDARY_HEADER_BYTES + 8
"""The standard caps a packet at 512 KiB of data (plus headers and checksum)."""

TIME_F1 = 0x11
MS1553_F1 = 0x19
ARINC429_F0 = 0x38

CSDW_BYTES = 4
"""Every data packet's body starts with a 4-byte channel-specific data word."""

_HEADER = struct.Struct("<HHIIBBBB6sH")

_SCAN_BLOCK = 1 << 20
RECOGNIZE_BYTES = 2 * MAX_PACKET_BYTES
"""How far into a file whose first header is damaged :func:`looks_like_chapter10` looks."""


@dataclass(frozen=True, slots=True)
class ReadIssue:
    """A damaged or unreadable part of the file, skipped."""

    offset: int
    text: str

    def __str__(self) -> str:
        return f"offset {self.offset}: {self.text}"


@dataclass(frozen=True, slots=True)
class Header:
    """The primary packet header fields the reader needs."""

    offset: int
    channel_id: int
    packet_length: int
    data_length: int
    sequence_number: int
    flags: int
    data_type: int
    rtc: int
    """The 48-bit relative time counter (10 MHz) when the packet's first data was seen."""

    @property
    def secondary_header(self) -> bool:
        return bool(self.flags & 0x80)

    @property
    def ipts_source(self) -> int:
        """0: message time stamps are relative-time-counter values; 1: secondary-header time."""
        return self.flags >> 6 & 1

    @property
    def secondary_format(self) -> int:
        return self.flags >> 2 & 3

    @property
    def checksum_kind(self) -> int:
        """0 none, 1 8-bit, 2 16-bit, 3 32-bit data checksum."""
        return self.flags & 3


def parse_header(raw: bytes, offset: int) -> Header | str:
    """A header from 24 bytes, or why they are not one."""
    sync, channel, plen, dlen, _version, seq, flags, dtype, rtc, checksum = _HEADER.unpack(raw)
    if sync != SYNC_PATTERN:
        return f"bad sync pattern 0x{sync:04X} (expected 0xEB25)"
    if sum(array("H", raw[:22])) & 0xFFFF != checksum:
        return "header checksum mismatch"
    header_len = HEADER_BYTES + (SECONDARY_HEADER_BYTES if flags & 0x80 else 0)
    if plen % 4 or plen > MAX_PACKET_BYTES or plen < header_len + dlen:
        return f"impossible lengths (packet {plen} bytes, data {dlen} bytes)"
    return Header(offset, channel, plen, dlen, seq, flags, dtype,
                  int.from_bytes(rtc, "little"))


def _data_checksum_ok(header: Header, raw: bytes) -> bool:
    kind = header.checksum_kind
    if kind == 0:
        return True
    size = (0, 1, 2, 4)[kind]
    start = HEADER_BYTES + (SECONDARY_HEADER_BYTES if header.secondary_header else 0)
    body = raw[start:len(raw) - size]
    body = body[:len(body) - len(body) % size]
    values = np.frombuffer(body, ("u1", "u1", "<u2", "<u4")[kind])
    total = int(values.sum(dtype=np.uint64)) & (1 << 8 * size) - 1
    stored = int.from_bytes(raw[len(raw) - size:], "little")
    return total == stored


@dataclass(frozen=True, slots=True)
class RawPacket:
    """One framed, checked packet: its header, its bytes and pychapter10's parse of them."""

    header: Header
    raw: bytes
    packet: Any
    """The pychapter10 packet object (``MS1553F1``, ``TimeF1``, ``ARINC429F0`` ...); None
    for the walker's ``raw_types``."""
    cut: str = ""
    """Where and how a packet of the ``raw_types`` was cut short ("" for a whole packet):
    ``raw`` then holds only the bytes up to the cut (the end of the file, or the next packet
    header), and its reader keeps every message wholly before the cut and reports the cut
    once. No data checksum vouches for such a packet; its headers and lengths still must
    agree."""


class PacketWalker:
    """Iterate the packets of one file (``data_types``: the types to parse, others are
    framed, checked and passed over). Damaged packets land in :attr:`issues`.

    ``position`` and ``size`` tell how far the walk has come (for a progress bar).
    """

    def __init__(self, path: str | Path, data_types: frozenset[int] | None = None,
                 raw_types: frozenset[int] = frozenset(), name: str | None = None) -> None:
        self.path = Path(path)
        self.name = str(self.path) if name is None else name
        """What messages call the input (``stdin`` for a stream spooled to ``path``)."""
        try:
            self._file: BinaryIO = self.path.open("rb")
        except OSError as error:
            raise CaptureFormatError(f"{self.name}: cannot open: {error.strerror}") from error
        self.size = self.path.stat().st_size
        self.position = 0
        self.data_types = data_types
        self.raw_types = raw_types
        """Types yielded framed and checked but not parsed (``RawPacket.packet`` None) unless
        they have a secondary header."""
        self.issues: list[ReadIssue] = []
        self.packets_read = 0
        self.headers_seen = 0
        """Valid packet headers met (of any type)."""
        self.first_rtc: int | None = None
        """The relative time counter of the file's first valid packet."""
        self.types_seen: dict[int, set[int]] = {}
        """Data type -> channel IDs of the whole packets met so far (read or passed over):
        what the recording holds, for saying so when it holds nothing asked for."""

    def close(self) -> None:
        self._file.close()

    def __iter__(self) -> Iterator[RawPacket]:
        f = self._file
        pos = 0
        passed: int | None = None
        """Where the last packet passed over by its length alone starts (not read: a type
        not asked for), until the header after it proves that length right."""
        recheck = -1
        while True:
            f.seek(pos)
            raw_header = f.read(HEADER_BYTES)
            self.position = pos
            if len(raw_header) < HEADER_BYTES:
                if raw_header and passed is not None:   # read and check it after all
                    pos, recheck, passed = passed, passed, None
                    continue
                if raw_header:
                    self._issue(pos, f"truncated packet header ({len(raw_header)} bytes at the "
                                     "end of the file)")
                self.position = self.size
                return
            header = parse_header(raw_header, pos)
            if isinstance(header, str):
                if passed is not None:   # a damaged or cut packet passed over: read it
                    pos, recheck, passed = passed, passed, None
                    continue
                self._issue(pos, header)
                pos = self._next_header(pos + 1)
                continue
            passed = None
            if pos != recheck:
                self.headers_seen += 1
            if self.first_rtc is None:
                self.first_rtc = header.rtc
            next_pos = pos + header.packet_length
            if (pos != recheck and next_pos <= self.size and self.data_types is not None
                    and header.data_type not in self.data_types
                    and header.data_type not in self.raw_types):
                # not asked for: passed over by its length, unread (its data checksum
                # unchecked unless the header after it is not where that length says)
                self.types_seen.setdefault(header.data_type, set()).add(header.channel_id)
                passed = pos
                pos = next_pos
                self.position = pos
                continue
            rest = f.read(header.packet_length - HEADER_BYTES)
            raw = raw_header + rest
            if len(raw) < header.packet_length:
                # a cut last packet, or a damaged length: a valid header further on says which
                following = self._next_header(pos + HEADER_BYTES)
                where = ("at the end of the file" if following >= self.size else
                         f"by the packet header at offset {following}")
                kept = self._cut(header, raw[:following - pos], where)
                if kept is not None:
                    yield kept
                    if following >= self.size:
                        self.position = self.size
                        return
                    pos = following
                    continue
                if following < self.size:
                    self._issue(pos, f"packet length {header.packet_length} runs past the end "
                                     f"of the file, but a packet header follows at offset "
                                     f"{following} (type 0x{header.data_type:02X}, channel "
                                     f"{header.channel_id}); packet skipped")
                    pos = following
                    continue
                self._issue(pos, f"truncated packet (type 0x{header.data_type:02X}, "
                                 f"{len(raw)} of {header.packet_length} bytes at the end of "
                                 "the file)")
                self.position = self.size
                return
            if not _data_checksum_ok(header, raw):
                following = self._next_header(pos + HEADER_BYTES)  # it may be a cut packet
                if following < next_pos:
                    kept = self._cut(header, raw[:following - pos],
                                     f"by the packet header at offset {following}")
                    if kept is not None:
                        yield kept
                        pos = following
                        continue
                self._issue(pos, f"data checksum mismatch (type 0x{header.data_type:02X}, "
                                 f"channel {header.channel_id}); packet skipped")
                pos = following
                continue
            pos = next_pos
            self.position = pos
            self.types_seen.setdefault(header.data_type, set()).add(header.channel_id)
            if self.data_types is not None and header.data_type not in self.data_types:
                continue
            handler = TYPES.get(header.data_type)
            if handler is None:
                continue
            if header.data_length < CSDW_BYTES:
                self._issue(header.offset, f"data length {header.data_length} bytes leaves no "
                                           "room for the channel-specific word (type "
                                           f"0x{header.data_type:02X}, channel "
                                           f"{header.channel_id}); packet skipped")
                continue
            if header.data_type in self.raw_types and not header.secondary_header:
                # (a secondary header's time is pychapter10's to judge, as for other types)
                self.packets_read += 1
                yield RawPacket(header, raw, None)
                continue
            body_end = HEADER_BYTES + header.data_length + \
                (SECONDARY_HEADER_BYTES if header.secondary_header else 0)
            try:  # parsed without filler and checksum: a message cannot run into them
                packet = handler(BytesIO(raw[:body_end]))
            except Exception as error:
                # pychapter10 parses bytes nobody vouches for, and what it raises on damaged
                # input is not part of its API (InvalidPacket, EOFError, struct.error, but also
                # TypeError and ValueError from bitstruct and datetime on short or nonsensical
                # fields). Whatever it raises for one packet is that packet's damage.
                self._issue(header.offset, f"unreadable packet (type 0x{header.data_type:02X}, "
                                           f"channel {header.channel_id}): "
                                           f"{type(error).__name__}: {error}; packet skipped")
                continue
            self.packets_read += 1
            yield RawPacket(header, raw, packet)

    def _cut(self, header: Header, raw: bytes, where: str) -> RawPacket | None:
        """A packet cut short ``where`` as a :attr:`RawPacket.cut` one, when it is of the
        ``raw_types`` (whose reader keeps its whole messages) and holds its
        channel-specific word; None otherwise (the caller skips and reports it)."""
        body = HEADER_BYTES + CSDW_BYTES
        if (header.data_type not in self.raw_types or header.secondary_header
                or len(raw) < body or header.data_length < CSDW_BYTES):
            return None
        self.packets_read += 1
        self.types_seen.setdefault(header.data_type, set()).add(header.channel_id)
        return RawPacket(header, raw, None, cut=(
            f"packet (type 0x{header.data_type:02X}, channel {header.channel_id}) cut short "
            f"{where} ({len(raw)} of {header.packet_length} bytes)"))

    def _issue(self, offset: int, text: str) -> None:
        self.issues.append(ReadIssue(offset, text))

    def _next_header(self, start: int) -> int:
        """The offset of the next valid packet header at or after ``start`` (the file size
        when there is none)."""
        f = self._file
        pos = start
        while pos < self.size:
            f.seek(pos)
            block = f.read(_SCAN_BLOCK + HEADER_BYTES)
            found = block.find(SYNC_BYTES)
            while found != -1 and found + HEADER_BYTES <= len(block):
                if isinstance(parse_header(block[found:found + HEADER_BYTES], pos + found),
                              Header):
                    return pos + found
                found = block.find(SYNC_BYTES, found + 1)
            if len(block) <= _SCAN_BLOCK:
                break
            pos += _SCAN_BLOCK
        return self.size


def looks_like_chapter10(path: str | Path) -> bool:
    """True when the file starts with a valid Chapter 10 packet header, or, its first header
    being damaged, when a valid header within the first :data:`RECOGNIZE_BYTES` is followed
    by another valid header (or the end of the file) exactly where its length says. Two
    headers that agree are what no other kind of file holds by chance (a lone sync pattern
    with a matching checksum turns up in random bytes about once in 4 GB)."""
    try:
        with Path(path).open("rb") as f:
            block = f.read(RECOGNIZE_BYTES + HEADER_BYTES)
            size = os.fstat(f.fileno()).st_size
    except OSError:
        return False
    if len(block) >= HEADER_BYTES and isinstance(parse_header(block[:HEADER_BYTES], 0), Header):
        return True
    found = block.find(SYNC_BYTES)
    while found != -1 and found + HEADER_BYTES <= len(block):
        header = parse_header(block[found:found + HEADER_BYTES], found)
        if isinstance(header, Header):
            end = found + header.packet_length
            if end == size:
                return True
            following = block[end:end + HEADER_BYTES]
            if len(following) == HEADER_BYTES and isinstance(parse_header(following, end),
                                                              Header):
                return True
        found = block.find(SYNC_BYTES, found + 1)
    return False
