"""Filler traffic that loads the testbed's bus to (nearly) 100 % (``testbed.fill_bus``).

A load test needs a bus that is busy all the time, the worst case the daemon must keep up
with. The ICD's schedule leaves most of each 2 ms minor frame idle, and unevenly (a message
sent every 5th frame leaves a hole in the other four). :func:`fill_schedule` keeps the ICD's
messages exactly as they are and adds BC -> RT transfers to a spare terminal (an address the
schedule does not use, which accepts every subaddress):

* for each periodic ICD message (every > 1 frames), one transfer of the same length in each
  frame where that message is not sent, so every frame carries the same amount of traffic;
* then 32-word transfers (and one shorter one) every frame up to ``target`` of the frame.

Messages sent once every 100 frames or less often (the BIT request and result) are not
mirrored: they overrun their frame by a few tens of µs, which the bus controller absorbs by
starting the next frame later. The bus load the monitor measures (``BusStatistics``) is the
figure to quote, not ``target``.
"""

from __future__ import annotations

import dataclasses

from drivers.backends.loopback import RemoteTerminal, Schedule, ScheduledMessage

WORD_NS = 20_000
GAP_NS = 10_000
"""The bus controller's intermessage gap (loopback default)."""
RESPONSE_NS = 8_000
"""Dead time per response (the loopback's default response gap, mid to mid, rounded up)."""
RARE_EVERY = 100
"""Messages sent less often than this are not mirrored."""


def words_of(message: ScheduledMessage) -> tuple[int, int]:
    """(words on the bus, responses) of one transfer: command(s), data, status(es)."""
    if message.is_mode:
        data = 1 if message.count >= 16 else 0
        return 2 + data, 1
    if message.rt2 is not None:
        return 4 + message.count, 2
    return 2 + message.count, 1


def duration_ns(message: ScheduledMessage) -> int:
    """Bus time of one transfer, intermessage gap included."""
    words, responses = words_of(message)
    return words * WORD_NS + responses * RESPONSE_NS + GAP_NS


def spare_address(schedule: Schedule, taken: set[int]) -> int:
    """The highest RT address neither the schedule nor ``taken`` uses."""
    used = taken | {m.rt for m in schedule.messages} | \
        {m.rt2 for m in schedule.messages if m.rt2 is not None}
    for address in range(30, -1, -1):
        if address not in used:
            return address
    raise ValueError("no spare RT address for filler traffic")


def _filler(rt: int, sa: int, count: int, every: int, offset: int) -> ScheduledMessage:
    return ScheduledMessage(rt, sa, False, count, every=every, offset=offset,
                            name=f"filler RT{rt:02d} SA{sa:02d}")


def fill_schedule(schedule: Schedule, taken: set[int] | None = None,
                  target: float = 1.0) -> tuple[Schedule, RemoteTerminal]:
    """``schedule`` plus filler transfers (see the module docstring), and the terminal that
    receives them."""
    rt = spare_address(schedule, taken or set())
    fillers: list[ScheduledMessage] = []
    per_frame = 0
    for message in schedule.messages:
        if message.every == 1:
            per_frame += duration_ns(message)
        elif message.every < RARE_EVERY:
            per_frame += duration_ns(message)
            words, _ = words_of(message)
            count = min(32, max(1, words - 2))
            for offset in range(message.every):
                if offset != message.offset % message.every:
                    fillers.append(_filler(rt, 1 + len(fillers) % 30, count, message.every,
                                           offset))
    free = int(schedule.frame_ns * target) - per_frame
    full = duration_ns(_filler(rt, 1, 32, 1, 0))
    sa = 1
    while free >= duration_ns(_filler(rt, 1, 1, 1, 0)):
        count = 32 if free >= full else (free - GAP_NS - RESPONSE_NS) // WORD_NS - 2
        message = _filler(rt, sa, count, 1, 0)
        fillers.append(message)
        free -= duration_ns(message)
        sa = sa % 30 + 1
    filled = dataclasses.replace(schedule, messages=(*schedule.messages, *fillers))
    return filled, RemoteTerminal(rt)
