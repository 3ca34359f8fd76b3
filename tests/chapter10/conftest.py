"""Fixtures of the Chapter 10 tests: the sample recording, and packets built byte by byte.

``sample_c10`` is the real recording kept next to the repository (skipped when absent).
``c10`` builds packets with pychapter10's classes, independently of the recording code, so a
reader test controls every field: block status bits, gaps, time-tag bits, checksums.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import pytest
from chapter10.arinc429 import ARINC429F0
from chapter10.ms1553 import MS1553F1
from chapter10.time import TimeF1
from chapter10.util import BitFormat

SAMPLE = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "chapter10" / \
    "sample.c10"


@pytest.fixture(scope="session")
def sample_c10() -> Path:
    if not SAMPLE.is_file():
        pytest.skip(f"the sample Chapter 10 recording is not at {SAMPLE}")
    return SAMPLE


class _Ms1553(MS1553F1):  # type: ignore[misc]
    """The standard's CSDW layout: count in bits 23-0, time-tag bits in 31-30."""

    csdw_format = BitFormat("""
        u24 count
        u2 time_tag_bits
        p6""")


@dataclass(frozen=True)
class Message:
    """One 1553 message as a recorder stores it."""

    words: tuple[int, ...]
    ipts: int
    block_status: int = 0
    gap1: int = 0
    gap2: int = 0


class C10Builder:
    """Packets as bytes (pychapter10 lays out headers, filler and checksums)."""

    Message = Message

    @staticmethod
    def ms1553(messages: list[Message], *, channel: int = 1, rtc: int | None = None,
               time_tag_bits: int = 1, checksum: int = 2) -> bytes:
        packet = _Ms1553(data_type=0x19, channel_id=channel, header_version=3,
                         data_checksum=checksum,
                         rtc=messages[0].ipts if rtc is None else rtc,
                         time_tag_bits=time_tag_bits, count=len(messages))
        for m in messages:
            data = struct.pack(f"<{len(m.words)}H", *m.words)
            bs = m.block_status
            packet.append(MS1553F1.Message(
                data=data, ipts=m.ipts, gap_time=m.gap1 | m.gap2 << 8, length=len(data),
                bus=bs >> 13 & 1, me=bs >> 12 & 1, rt2rt=bs >> 11 & 1, fe=bs >> 10 & 1,
                timeout=bs >> 9 & 1, le=bs >> 5 & 1, se=bs >> 4 & 1, we=bs >> 3 & 1))
        return bytes(packet)

    @staticmethod
    def time(rtc: int, when: datetime, *, day_format: bool = False) -> bytes:
        packet = TimeF1(data_type=0x11, channel_id=1, header_version=3, rtc=rtc,
                        date_format=0 if day_format else 1, data_checksum=2)
        packet.time = when
        return bytes(packet)

    @staticmethod
    def arinc429(words: list[int], *, rtc: int, gaps: list[int], bus: int = 0,
                 parity_error: bool = False, channel: int = 9) -> bytes:
        packet = ARINC429F0(data_type=0x38, channel_id=channel, header_version=3, rtc=rtc,
                            count=len(words), data_checksum=2)
        for word, gap in zip(words, gaps, strict=True):
            packet.append(ARINC429F0.Message(data=struct.pack("<I", word), gap_time=gap,
                                             bus=bus, bus_speed=1,
                                             parity_error=int(parity_error)))
        return bytes(packet)


@pytest.fixture
def c10() -> C10Builder:
    return C10Builder()
