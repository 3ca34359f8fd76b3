"""Chapter 10 time: the 10 MHz relative time counter, and absolute time from time packets.

Every packet header and every 1553 message carries a 48-bit relative time counter (RTC)
value, 100 ns a count. :class:`Timebase` turns it into ``t_ns``, ns since the first packet of
the file (the counter's own zero means nothing), allowing for the counter's wrap.

Time data packets (type 0x11, format 1) pair an RTC value with the time of day (IRIG, GPS or
the recorder's clock) in BCD. From the latest one, :meth:`Timebase.absolute` gives the time of
any RTC value as ISO 8601 text. In the day-of-year format the packet has no year: pass
``year=`` to get a full date; without it the text is ``day DDD HH:MM:SS.ffffff``
(pychapter10 itself would use the current year, which would make a replay depend on the day
it runs).
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any

RTC_BITS = 48
RTC_NS = 100
"""Nanoseconds per count of the 10 MHz relative time counter."""

_EPOCH = datetime(1970, 1, 1)
_RTC_MOD = 1 << RTC_BITS
_RTC_HALF = 1 << (RTC_BITS - 1)


@dataclass(frozen=True, slots=True)
class TimeReference:
    """One time packet: the time of day it gives, at its RTC value."""

    rtc: int
    day_of_year: int | None
    """Set in the day format (1 = 1 January); None when the packet gives a full date."""
    date: datetime | None
    """The full date and time (month-and-year format, or day format with a known year)."""
    seconds_of_day: float
    source: int
    """The time packet's time source (0 internal, 1 external, 2 internal from RMM, 15 none)."""


def time_reference(packet: Any, rtc: int, year: int | None = None) -> TimeReference:
    """Read a pychapter10 ``TimeF1`` packet's BCD fields (``rtc``: its header's counter)."""
    ms = packet.Hmn * 100 + packet.Tmn * 10
    seconds = packet.Sn + packet.TSn * 10
    minutes = packet.Mn + packet.TMn * 10
    hours = packet.Hn + packet.THn * 10
    of_day = hours * 3600 + minutes * 60 + seconds + ms / 1000
    if packet.date_format:
        month = packet.On + packet.TOn * 10
        day = packet.Dn + packet.TDn * 10
        full_year = packet.Yn + packet.TYn * 10 + packet.HYn * 100 + packet.OYn * 1000
        full = datetime(full_year, month, day) + timedelta(seconds=of_day)
        return TimeReference(rtc, None, full, of_day, packet.time_source)
    day_of_year = packet.Dn + packet.TDn * 10 + packet.HDn * 100
    date: datetime | None = None
    if year is not None:
        date = datetime(year, 1, 1) + timedelta(days=day_of_year - 1, seconds=of_day)
    return TimeReference(rtc, day_of_year, date, of_day, packet.time_source)


class Timebase:
    """RTC values to ``t_ns`` and to absolute time."""

    def __init__(self, year: int | None = None) -> None:
        self.origin: int | None = None
        """The RTC value of the file's first packet: ``t_ns`` 0."""
        self.year = year
        self.reference: TimeReference | None = None
        self._base = datetime(2000, 1, 1)

    def start(self, rtc: int) -> None:
        """Set the origin, once (the first packet's counter)."""
        if self.origin is None:
            self.origin = rtc

    def ns(self, rtc: int) -> int:
        """ns from the origin to counter value ``rtc`` (negative just before it)."""
        self.start(rtc)
        assert self.origin is not None
        delta = (rtc - self.origin) % _RTC_MOD
        if delta >= _RTC_HALF:
            delta -= _RTC_MOD
        return delta * RTC_NS

    def add_time_packet(self, packet: Any, rtc: int) -> None:
        ref = time_reference(packet, rtc, self.year)
        self.reference = ref
        if ref.date is not None:
            self._base = ref.date
        else:
            assert ref.day_of_year is not None  # 2000 is a leap year: day 366 exists
            self._base = datetime(2000, 1, 1) + timedelta(days=ref.day_of_year - 1,
                                                          seconds=ref.seconds_of_day)

    def epoch_ns(self, rtc: int) -> int | None:
        """The time of counter value ``rtc`` in ns since 1970-01-01 UTC, exact in integers
        (a time packet's date is UTC by convention); None before any time packet, or while
        the packets give no full date (day-of-year format without ``year``)."""
        ref = self.reference
        if ref is None or ref.date is None:
            return None
        delta = (rtc - ref.rtc) % _RTC_MOD
        if delta >= _RTC_HALF:
            delta -= _RTC_MOD
        return (ref.date - _EPOCH) // timedelta(microseconds=1) * 1000 + delta * RTC_NS

    def absolute(self, rtc: int) -> str | None:
        """The time of counter value ``rtc`` as ISO 8601 text (None before any time packet)."""
        ref = self.reference
        if ref is None:
            return None
        delta = (rtc - ref.rtc) % _RTC_MOD
        if delta >= _RTC_HALF:
            delta -= _RTC_MOD
        moment = self._base + timedelta(microseconds=delta * RTC_NS / 1000)
        if ref.date is not None:
            return moment.isoformat(timespec="microseconds")
        return f"day {moment.timetuple().tm_yday:03d} {moment:%H:%M:%S.%f}"
