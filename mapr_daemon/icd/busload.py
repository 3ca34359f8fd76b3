"""Bus time and bus load of a schedule: how much of the 1 Mb/s bus the table uses.

A 1553 word (sync, 16 bits, parity) takes 20 µs. A message costs its words plus a response
time before each status word plus the gap the bus controller leaves before the next message,
both dead bus time as given in the schedule (worst case by default: the standard allows an
RT up to 12 µs mid-bit to mid-bit, i.e. 10 µs of dead bus). The load is the sum over the
scheduled messages of rate x duration; the busiest minor frame must also fit in its slot.

>>> from mapr_daemon.icd.model import Message
>>> m = Message("m", rt=5, rt_name="ema", transmit=True, subaddress=1, word_count=4, rate_hz=100)
>>> message_time_us(m, response_time_us=10, intermessage_gap_us=10)
140.0
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from mapr_daemon.icd.model import Message, Schedule

WORD_US = 20.0
"""One word on the bus at 1 Mb/s: 3 sync bit times, 16 bits, parity."""


def message_words(message: Message) -> tuple[int, int]:
    """(words on the bus, status responses) of one transfer of ``message``."""
    if message.source is not None:        # rx cmd, tx cmd ** status, data ** status
        return 2 + message.word_count + 2, 2
    return 1 + message.word_count + 1, 1    # cmd (+data) ** status (+data)


def message_time_us(message: Message, *, response_time_us: float,
                    intermessage_gap_us: float) -> float:
    """Bus time of one transfer, gap to the next message included."""
    words, responses = message_words(message)
    return words * WORD_US + responses * response_time_us + intermessage_gap_us


def frame_slots(schedule: Schedule, messages: Mapping[str, Message],
                index: int) -> tuple[tuple[float, Message], ...]:
    """What the bus controller sends in minor frame ``index``: (start µs in the frame, message).

    Messages go back to back from the frame's start in schedule order, each taking
    :func:`message_time_us`. The loopback bus controller and the benches replay this.
    """
    slots = []
    t = 0.0
    for name in schedule.frame(index):
        message = messages[name]
        slots.append((t, message))
        t += message_time_us(message, response_time_us=schedule.response_time_us,
                             intermessage_gap_us=schedule.intermessage_gap_us)
    return tuple(slots)


@dataclass(frozen=True, slots=True)
class BusLoad:
    """The load a schedule puts on the bus."""

    load: float
    """Average fraction of bus time used (0.25 = 25 %)."""
    words_per_s: float
    """Words per second on the bus (commands, status and data)."""
    data_words_per_s: float
    frame_us: tuple[float, ...]
    """Bus time used in each minor frame of the major frame."""
    minor_frame_us: int

    @property
    def busiest_frame_us(self) -> float:
        return max(self.frame_us, default=0.0)

    @property
    def peak_frame_load(self) -> float:
        """Fraction of the busiest minor frame that is used."""
        return self.busiest_frame_us / self.minor_frame_us


def bus_load(schedule: Schedule, messages: Mapping[str, Message]) -> BusLoad:
    """Compute the :class:`BusLoad` of ``schedule`` over the named ``messages``."""
    cost = {
        e.message: message_time_us(messages[e.message],
                                   response_time_us=schedule.response_time_us,
                                   intermessage_gap_us=schedule.intermessage_gap_us)
        for e in schedule.entries
    }
    frames = tuple(sum(cost[name] for name in schedule.frame(k))
                   for k in range(schedule.minor_frames))
    load = sum(frames) / schedule.major_frame_us
    words = data = 0.0
    for entry in schedule.entries:
        rate = schedule.rate_hz(entry)
        message = messages[entry.message]
        words += rate * message_words(message)[0]
        data += rate * message.word_count
    return BusLoad(load=load, words_per_s=words, data_words_per_s=data, frame_us=frames,
                   minor_frame_us=schedule.minor_frame_us)
