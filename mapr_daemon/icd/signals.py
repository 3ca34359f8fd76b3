"""A monitor's records -> per-parameter time series: what the reasoner consumes.

:class:`SignalStream` decodes records in chunks with :meth:`Icd.decode_batch` and hands back,
per chunk, one :class:`Series` per parameter. For a message whose repeating group has a block
``counter`` it also watches the counter across chunks:

- a block whose counter did not move is a repeat (the bus controller read the same block
  twice); it is dropped and counted in :attr:`StreamStats.repeated_blocks`;
- a counter that jumped by more than one means blocks were lost; they are counted in
  :attr:`StreamStats.lost_blocks` and the first samples after the hole carry
  :data:`~mapr_daemon.icd.flags.FLAG_AFTER_GAP`.

Sample times inside a block come from the record's time tag (see :class:`Group`); the counter
only says which blocks are missing or repeated, so a time series stays honest about holes.

>>> stream = SignalStream(icd)                               # doctest: +SKIP
>>> for chunk in stream.stream(monitor):                     # doctest: +SKIP
...     reasoner.update(chunk["phase_current_a"])
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from itertools import islice

import numpy as np

from drivers.chapter10.ms1553_batch import Ms1553Batch
from drivers.mil1553.record import MonitorRecord
from mapr_daemon.icd.columns import decode_columns
from mapr_daemon.icd.database import Icd
from mapr_daemon.icd.flags import FLAG_AFTER_GAP
from mapr_daemon.icd.model import Group, Message
from mapr_daemon.icd.values import I64, Series

CLOCK_SLACK = 50e-6
"""How fast (s/s) the counter timebase may move forward to follow a terminal's clock drift."""


@dataclass(slots=True)
class StreamStats:
    """Counts since the stream started."""

    records: int = 0
    decoded: int = 0
    unmatched: int = 0
    empty: int = 0
    data_words: int = 0
    repeated_blocks: int = 0
    lost_blocks: int = 0


class SignalStream:
    """Decode records into per-parameter series, chunk after chunk, tracking block counters.

    ``parameters`` limits the output to those names (all by default). ``timebase`` says how
    samples of a group with a block counter are timed: ``"counter"`` (default) spaces them
    uniformly on the counter, anchored to the record time tags; ``"record"`` keeps the
    per-record times of :class:`~mapr_daemon.icd.model.Group` (which carry the bus
    controller's polling jitter).
    """

    def __init__(self, icd: Icd, *, parameters: Iterable[str] | None = None,
                 chunk: int = 4096, timebase: str = "counter") -> None:
        if timebase not in ("counter", "record"):
            raise ValueError(f"timebase must be 'counter' or 'record', got {timebase!r}")
        self.icd = icd
        self.timebase = timebase
        self.chunk = chunk
        self.stats = StreamStats()
        wanted = None if parameters is None else set(parameters)
        if wanted is not None:
            unknown = wanted - set(icd.parameter_names)
            if unknown:
                raise KeyError(f"no parameter named {', '.join(sorted(unknown))}")
        self._wanted = wanted
        self._blocks: dict[str, _BlockState] = {}

    def feed(self, records: Iterable[MonitorRecord] | Ms1553Batch) -> dict[str, Series]:
        """Decode ``records`` (in time order) and return their series. A Chapter 10
        reader's batch of columns is decoded as its records would be, without building
        them (:mod:`mapr_daemon.icd.columns`)."""
        batch = decode_columns(self.icd, records) if isinstance(records, Ms1553Batch) \
            else self.icd.decode_batch(records)
        s = self.stats
        s.decoded += sum(batch.records.values())
        s.unmatched += batch.unmatched
        s.empty += batch.empty
        s.records += sum(batch.records.values()) + batch.unmatched + batch.empty
        s.data_words += batch.data_words
        series = batch.series
        for name, n in batch.records.items():
            message = self.icd.message(name)
            if message.group is not None and message.group.counter is not None:
                self._check_counter(message, n, series)
        if self._wanted is not None:
            series = {k: v for k, v in series.items() if k in self._wanted}
        return series

    def stream(self, records: Iterable[MonitorRecord]) -> Iterator[dict[str, Series]]:
        """Feed ``records`` ``chunk`` at a time, yielding each chunk's series."""
        it = iter(records)
        while True:
            block = list(islice(it, self.chunk))
            if not block:
                return
            yield self.feed(block)

    def _check_counter(self, message: Message, n: int, series: dict[str, Series]) -> None:
        group = message.group
        assert group is not None and group.counter is not None
        state = self._blocks.setdefault(message.name, _BlockState())
        raw = series[group.counter].raw
        modulus = 1 << series[group.counter].parameter.width
        previous = np.empty(n, dtype=np.int64)
        previous[1:] = raw[:-1]
        previous[0] = raw[0] - 1 if state.last is None else state.last
        step = (raw - previous) % modulus
        index = state.index + np.cumsum(step)
        state.last = int(raw[-1])
        state.index = int(index[-1])
        repeat = step == 0
        gap = step > 1
        self.stats.repeated_blocks += int(repeat.sum())
        self.stats.lost_blocks += int((step[gap] - 1).sum())
        channels = {c.name for c in group.channels}
        if self.timebase == "counter":
            self._counter_times(group, state, index, series, channels)
        for p in message.all_parameters():
            s = series[p.name]
            per = len(s) // n
            if gap.any():
                first = np.zeros(len(s), dtype=np.bool_)
                first[np.flatnonzero(gap) * per] = True
                s.flags[first] |= FLAG_AFTER_GAP
            if repeat.any():
                series[p.name] = s.take(np.repeat(~repeat, per))

    def _counter_times(self, group: Group, state: _BlockState, index: I64,
                       series: dict[str, Series], channels: set[str]) -> None:
        """Re-time group samples on the block counter: uniform periods, no bus jitter.

        Block k's first sample is at ``k * block + offset``. The offset is the smallest
        (record-derived first-sample time - k * block) seen so far — the bus controller reads
        a block late, never early — allowed to creep forward by :data:`CLOCK_SLACK` to follow
        a terminal clock that runs slow against ours. The first chunk seeds it with its best
        block, so the stream's first samples are timed like the rest.
        """
        period = group.period_ns
        block = group.samples * period
        sample = series[group.channels[0].name]
        t_first = sample.t_ns[:: group.samples].astype(np.float64)
        late = t_first - index * block           # offset seen by each block, >= the true one
        if state.anchor is None:                 # bootstrap on the first chunk's best block
            state.anchor = float(t_first[0])
            state.floor = float(late.min())
        since = t_first - state.anchor
        lead = late - CLOCK_SLACK * since
        floor = np.minimum.accumulate(np.concatenate(([state.floor], lead)))[1:]
        state.floor = float(floor[-1])
        start = index * block + floor + CLOCK_SLACK * since
        times = np.round(start[:, None] + np.arange(group.samples) * period).astype(np.int64)
        for name in channels:
            s = series[name]
            series[name] = Series(s.parameter, times.ravel(), s.value, s.raw, s.flags)


@dataclass(slots=True)
class _BlockState:
    """Per message: last counter value, unwrapped block index, timing floor."""

    last: int | None = None
    index: int = -1
    anchor: float | None = None
    floor: float = math.inf


def collect(icd: Icd, records: Iterable[MonitorRecord], *,
            parameters: Iterable[str] | None = None, chunk: int = 4096,
            timebase: str = "counter") -> tuple[dict[str, Series], StreamStats]:
    """Decode everything in ``records`` into one series per parameter, and the counts."""
    stream = SignalStream(icd, parameters=parameters, chunk=chunk, timebase=timebase)
    parts: dict[str, list[Series]] = {}
    for piece in stream.stream(records):
        for name, s in piece.items():
            parts.setdefault(name, []).append(s)
    return {name: Series.concat(p) for name, p in parts.items()}, stream.stats
