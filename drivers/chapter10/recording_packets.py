"""Chapter 10 packets for a recording, built with pychapter10's packet classes.

pychapter10 lays out headers, message headers, filler, the header checksum and the data
checksum. Two things it gets wrong for writing are fixed here, not worked around downstream:

* its MIL-STD-1553 Format 1 channel-specific word puts the time-tag bits in bits 25-24; the
  standard (and irig106lib, and the sample recording) has them in bits 31-30. :class:`Ms1553F1`
  carries the corrected layout. (pychapter10 reading one of our files therefore reports
  ``time_tag_bits`` 0 where the file says 1, as it does for the sample.)
* its Time Data Format 1 constructor replaces a given ``time`` with the wall clock, so
  :func:`time_packet` sets the time after construction.

Every packet carries a 32-bit data checksum (packet flags bits 1-0 = 3) and data type version
0x03 (IRIG 106-07); the IPTS is the 48-bit relative time counter (no secondary header).
"""

from __future__ import annotations

import calendar
import struct
from collections.abc import Sequence
from datetime import datetime

from chapter10.computer import ComputerF1
from chapter10.ms1553 import MS1553F1
from chapter10.time import TimeF1
from chapter10.util import BitFormat

from drivers.chapter10.status import block_status_for
from drivers.mil1553.record import MonitorRecord, TransferFormat

DATA_TYPE_TMATS = 0x01
DATA_TYPE_TIME = 0x11
DATA_TYPE_1553 = 0x19
DATA_TYPE_VERSION = 0x03
"""Packet header data type version of IRIG 106-07."""
CHECKSUM_32 = 3
"""Packet flags bits 1-0: a 32-bit data checksum (sum of the body's 32-bit words)."""
TMATS_CHANNEL = 0
RTC_HZ = 10_000_000
"""The relative time counter ticks at 10 MHz: 100 ns per count."""
RTC_NS = 1_000_000_000 // RTC_HZ
RTC_MASK = (1 << 48) - 1
TIME_TAG_FIRST_BIT = 1
"""Time-tag bits: the time stamp is the first bit of the first word (our ``t_ns``)."""
GAP_MAX = 0xFF
"""A gap field holds 0-255 tenths of a microsecond."""
IPH_BYTES = 14
"""Per message: 8-byte time stamp, block status, gap word, length word."""

TIME_SOURCE_INTERNAL = 0
"""Time packet CSDW SRC: the recorder's (host's) own clock."""
TIME_FORMAT_RTC = 3
"""Time packet CSDW FMT: a real-time clock, not an IRIG time code input."""

_STATUS_BEFORE_DATA = frozenset({TransferFormat.RT_BC, TransferFormat.MODE_TX_DATA,
                                 TransferFormat.RT_RT, TransferFormat.BCAST_RT_RT})
"""Formats in which a terminal's status word precedes the data words it sends."""


class Ms1553F1(MS1553F1):  # type: ignore[misc]  # pychapter10 is untyped
    """pychapter10's MIL-STD-1553 Format 1 packet with the standard's CSDW layout: message
    count in bits 23-0, time-tag bits in bits 31-30."""

    csdw_format = BitFormat("""
        u24 count
        u2 time_tag_bits
        p6""")


def rtc_for(t_ns: int) -> int:
    """The 48-bit relative time counter for a time tag (ns from the start of the recording,
    which is count 0), rounded to the nearest 100 ns count."""
    return (t_ns + RTC_NS // 2) // RTC_NS & RTC_MASK


def words_in_bus_order(record: MonitorRecord) -> list[int]:
    """The record's words as they were on the bus: command(s), then, per the transfer
    format, the responding terminal's status before or after the data words.

    RT-RT: receive command, transmit command, transmitter's status, data, receiver's status.
    A missing response leaves its words out (a no-response message holds only what was on
    the bus). Words that fit no message (``UNKNOWN``) are written as they came.
    """
    words = [] if record.command is None else [record.command]
    if record.command2 is not None:
        words.append(record.command2)
    if record.format in _STATUS_BEFORE_DATA:
        words += [*record.status[:1], *record.data, *record.status[1:]]
    else:
        words += [*record.data, *record.status]
    return words


def gap_word(record: MonitorRecord) -> int:
    """GAP1 (low byte) and GAP2 (high byte) in 0.1 µs from the record's response gaps
    (mid-crossing to mid-crossing), rounded to the nearest tenth, clamped to 25.5 µs."""
    tenths = [min(GAP_MAX, max(0, (gap + 50) // 100)) for gap in record.gaps_ns[:2]]
    tenths += [0] * (2 - len(tenths))
    return tenths[0] | tenths[1] << 8


def ms1553_message(record: MonitorRecord) -> MS1553F1.Message:
    """One record as an MS1553F1 message: time stamp, block status, gaps, length, words."""
    words = words_in_bus_order(record)
    status = block_status_for(record)
    try:
        data = struct.pack(f"<{len(words)}H", *words)
    except struct.error:  # a value beyond 16 bits: keep its low 16, as a bus would carry
        data = struct.pack(f"<{len(words)}H", *(word & 0xFFFF for word in words))
    return MS1553F1.Message(
        data=data, ipts=rtc_for(record.t_ns), gap_time=gap_word(record), length=len(data),
        bus=status >> 13 & 1, me=status >> 12 & 1, rt2rt=status >> 11 & 1,
        fe=status >> 10 & 1, timeout=status >> 9 & 1, le=status >> 5 & 1,
        se=status >> 4 & 1, we=status >> 3 & 1)


def ms1553_packet(channel_id: int, sequence: int, records: Sequence[MonitorRecord]) -> bytes:
    """An MS1553F1 packet holding ``records`` (at least one), stamped with the first's time."""
    packet = Ms1553F1(channel_id=channel_id, data_type=DATA_TYPE_1553,
                      header_version=DATA_TYPE_VERSION, sequence_number=sequence & 0xFF,
                      data_checksum=CHECKSUM_32, rtc=rtc_for(records[0].t_ns),
                      time_tag_bits=TIME_TAG_FIRST_BIT, count=len(records))
    for record in records:
        packet.append(ms1553_message(record))
    return bytes(packet)


def time_packet(channel_id: int, sequence: int, rtc: int, when: datetime) -> bytes:
    """A Time Data Format 1 packet saying that counter value ``rtc`` is ``when`` (day, month,
    year format; the format resolves 10 ms, so ``when`` should be a multiple of it)."""
    packet = TimeF1(channel_id=channel_id, data_type=DATA_TYPE_TIME,
                    header_version=DATA_TYPE_VERSION, sequence_number=sequence & 0xFF,
                    data_checksum=CHECKSUM_32, rtc=rtc & RTC_MASK, date_format=1,
                    leap=int(calendar.isleap(when.year)), time_source=TIME_SOURCE_INTERNAL,
                    time_format=TIME_FORMAT_RTC)
    packet.time = when.replace(tzinfo=None)
    return bytes(packet)


def tmats_packet(sequence: int, text: str, version: int) -> bytes:
    """The computer-generated format 1 (setup record) packet on channel 0, ASCII TMATS."""
    packet = ComputerF1(channel_id=TMATS_CHANNEL, data_type=DATA_TYPE_TMATS,
                        header_version=DATA_TYPE_VERSION, sequence_number=sequence & 0xFF,
                        data_checksum=CHECKSUM_32, rtc=0, version=version, format=0,
                        data=text.encode("ascii"))
    return bytes(packet)
