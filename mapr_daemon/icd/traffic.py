"""Clean bus traffic from the table's schedule: records as a bus controller would produce them.

``schedule_records(icd, values, frames=...)`` walks the minor frames, asks ``values(message,
t_ns)`` for each scheduled message's engineering values, encodes them with the table and
yields well-formed :class:`MonitorRecord` objects time-stamped at their slot. It is what the
benches and tests use, and a reference for the loopback bus controller (which adds the word
timing, the terminals' behaviour and impairments).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping
from typing import Any

from drivers.mil1553.record import MonitorRecord
from mapr_daemon.icd.database import Icd
from mapr_daemon.icd.encoder import build_record, encode_message
from mapr_daemon.icd.errors import IcdError
from mapr_daemon.icd.model import Message, Parameter, ParamType

ValueSource = Callable[[Message, int], Mapping[str, Any]]
"""``values(message, t_ns)`` -> the message's engineering values at that time."""


def schedule_records(icd: Icd, values: ValueSource, *, frames: int, start_ns: int = 0,
                     bus: str = "A", strict: bool = True) -> Iterator[MonitorRecord]:
    """Records of ``frames`` minor frames of the schedule, starting at ``start_ns``."""
    if icd.schedule is None:
        raise IcdError("the table has no schedule", path=icd.path, field="schedule")
    frame_ns = icd.schedule.minor_frame_us * 1000
    for k in range(frames):
        base = start_ns + k * frame_ns
        for offset_us, message in icd.frame_slots(k):
            t_ns = base + round(offset_us * 1000)
            words = encode_message(message, values(message, t_ns), strict=strict)
            yield build_record(message, words, t_ns, bus=bus)


def pattern_value(p: Parameter, t_ns: int) -> Any:
    """A deterministic test pattern for parameter ``p`` at time ``t_ns``, inside its limits.

    Numbers follow a slow sine between the limits (or a quarter of the bits' range without
    limits), discretes toggle every 100 ms, enumerations step through their labels every
    100 ms, counters count milliseconds.
    """
    t_s = t_ns / 1e9
    step = int(t_ns // 100_000_000)
    if p.type is ParamType.DISCRETE:
        return step % 2
    if p.type is ParamType.ENUM:
        labels = sorted(p.labels.items())
        return labels[step % len(labels)][1]
    if p.type is ParamType.COUNTER:
        return int(t_ns // 1_000_000) % (1 << p.width)
    lo = p.minimum if p.minimum is not None else p.raw_min * p.scale + p.offset
    hi = p.maximum if p.maximum is not None else p.raw_max * p.scale + p.offset
    lo, hi = min(lo, hi), max(lo, hi)
    if p.minimum is None or p.maximum is None:
        middle, half = (lo + hi) / 2, (hi - lo) / 8
        lo, hi = middle - half, middle + half
    phase = (sum(map(ord, p.name)) % 628) / 100
    return lo + (hi - lo) * (0.5 + 0.45 * math.sin(2 * math.pi * 1.7 * t_s + phase))


def pattern_values(message: Message, t_ns: int) -> dict[str, Any]:
    """:func:`pattern_value` for every parameter of ``message`` sent at ``t_ns``.

    Group channels get one value per sample, at the sample times the decoder assigns from the
    record time (see :class:`~mapr_daemon.icd.model.Group`); a block counter counts blocks
    since t = 0 (``round(t_ns / block duration)``), so a message polled once per block
    counts up by one each time.
    """
    values = {p.name: pattern_value(p, t_ns) for p in message.parameters}
    g = message.group
    if g is None:
        return values
    times = [t_ns + round(dt) for dt in g.sample_offsets_ns()]
    for c in g.channels:
        values[c.name] = [pattern_value(c, t) for t in times]
    if g.counter is not None:
        counter = next(p for p in message.parameters if p.name == g.counter)
        values[g.counter] = round(t_ns / (g.samples * g.period_ns)) % (1 << counter.width)
    return values
