"""MS1553F1 packets to a struct of arrays, in numpy: :class:`Ms1553Batch`.

:mod:`drivers.chapter10.ms1553` builds one :class:`MonitorRecord` per message from
pychapter10's parse, which is what costs when a recording is read at full speed. Here the
packet's intra-packet headers are followed once (:mod:`drivers.chapter10.ms1553_walk`: a
short Python loop over offsets, then numpy gathers of stamps, status and words), and the
rest is numpy over all the messages of one or more packets:

* the split into command, data and status words depends on the command word(s), the word
  count and the time-out flag only, so :func:`~drivers.chapter10.layout.split_plan` runs
  once per distinct shape (a few hundred in a flight) and is broadcast;
* status-word checks, response-gap checks, block-status error names, time stamps, absolute
  time and epoch time are array expressions;
* errors are a bit set over :data:`~drivers.mil1553.record.MESSAGE_ERROR_NAMES`.

The batch gives exactly the records :func:`~drivers.chapter10.ms1553.records_from_packet`
gives (:meth:`Ms1553Batch.record`, built on demand), and the same problems, word for word.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from drivers.chapter10.layout import split_plan
from drivers.chapter10.ms1553 import TIME_TAG_COMMAND_END, TIME_TAG_LAST_BIT
from drivers.chapter10.ms1553_walk import Parts, gather
from drivers.chapter10.status import (
    BUS_B,
    FORMAT_ERROR,
    INVALID_WORD_ERROR,
    RESPONSE_TIMEOUT,
    RT_TO_RT,
    SYNC_TYPE_ERROR,
    WORD_COUNT_ERROR,
)
from drivers.chapter10.timebase import RTC_NS, Timebase, TimeReference
from drivers.mil1553.record import (
    MESSAGE_ERROR_NAMES,
    SLOT_SETTERS,
    MonitorRecord,
    TransferFormat,
    collector_paused,
)
from drivers.mil1553.timing import CONTIGUOUS_GAP_NS, BusTiming
from drivers.mil1553.wordbatch import WORD_TIME_NS

I64 = npt.NDArray[np.int64]
FORMATS: tuple[TransferFormat, ...] = tuple(TransferFormat)
"""``Ms1553Batch.format`` codes index this tuple."""
_FORMAT_CODE = {f: i for i, f in enumerate(FORMATS)}
ERROR_BIT = {name: 1 << i for i, name in enumerate(MESSAGE_ERROR_NAMES)}
"""The bit of each error name in ``Ms1553Batch.errors``."""

_RTC_MASK = (1 << 48) - 1
_RTC_MOD = 1 << 48
_RTC_HALF = 1 << 47
_STATUS_RESERVED = 0x00E0
_TIMING = BusTiming()
_EPOCH = datetime(1970, 1, 1)
NO_EPOCH = np.iinfo(np.int64).min
"""``Ms1553Batch.epoch_ns`` of a message whose time packets give no full date."""


@dataclass(frozen=True, slots=True)
class Ms1553Batch:
    """The 1553 messages of one or more MS1553F1 packets, one array element per message.

    Words of all messages sit in ``words``, in bus order; a message's data words are
    ``words[data_start:data_start + data_count]``, its status words ``status[:, :n_status]``
    and its response gaps ``gaps_ns[:, :n_status]``. ``format`` indexes :data:`FORMATS`;
    ``command2`` is -1 when there is none; ``errors`` is a bit set (:data:`ERROR_BIT`).
    ``time`` (ISO 8601 text, "" where the file has given no time packet yet) and
    ``epoch_ns`` (:data:`NO_EPOCH` where the time packets give no full date) are None when
    no message of the batch has one.
    """

    t_ns: I64
    end_ns: I64
    bus: npt.NDArray[np.uint8]
    format: npt.NDArray[np.uint8]
    command: I64
    command2: I64
    block_status: I64
    channel: I64
    offset: I64
    """File offset of the packet each message came from."""
    data_start: I64
    data_count: I64
    status: I64
    n_status: I64
    gaps_ns: I64
    errors: I64
    words: npt.NDArray[np.uint16]
    _time: npt.NDArray[np.str_] | TimeText | None
    epoch_ns: I64 | None
    word_errors: npt.NDArray[np.object_] | None = None
    """Each message's word errors as :attr:`MonitorRecord.word_errors` (an object array),
    None when no message has any (a Chapter 10 recording keeps none)."""

    def __len__(self) -> int:
        return int(self.t_ns.size)

    @property
    def time(self) -> npt.NDArray[np.str_] | None:
        """Each message's absolute time as text (ISO 8601, or ``day DDD HH:MM:SS.ffffff``
        from day-of-year time packets; "" where the file has given no time packet yet),
        None when no message of the batch has one; worked out on first use."""
        value = self._time
        if isinstance(value, TimeText):
            value = value.text()
            object.__setattr__(self, "_time", value)
        return value

    @property
    def rt(self) -> I64:
        return self.command >> 11 & 31

    @property
    def tr(self) -> I64:
        """1 for transmit, 0 for receive."""
        return self.command >> 10 & 1

    @property
    def sa(self) -> I64:
        return self.command >> 5 & 31

    def data(self, i: int) -> tuple[int, ...]:
        start = int(self.data_start[i])
        return tuple(self.words[start:start + int(self.data_count[i])].tolist())

    def record(self, i: int) -> MonitorRecord:
        """Message ``i`` as the record the per-message path builds."""
        return self.take(slice(i, i + 1)).records()[0]

    def records(self) -> list[MonitorRecord]:
        """Every message as a :class:`MonitorRecord`, as the per-message path builds it
        (``extra`` holds ``block_status`` and ``channel`` where they are not -1, ``time``
        and ``epoch_ns`` where the file gives them). Columns are turned into lists once and
        the records' slots set directly in one loop (:func:`~drivers.mil1553.record.
        new_records`' way), about three times as fast as calling ``MonitorRecord(...)``."""
        with collector_paused():
            return self._records()

    def _records(self) -> list[MonitorRecord]:
        n = len(self)
        if not n:
            return []
        words = tuple(self.words.tolist())
        starts = self.data_start.tolist()
        data = [words[a:e] for a, e in zip(starts, (self.data_start + self.data_count).tolist(),
                                           strict=True)]
        masks = self.errors.tolist()
        names = {m: error_names(m) for m in set(masks)}
        formats = [FORMATS[f] for f in self.format.tolist()]
        buses = [_BUS_NAMES[b] for b in self.bus.tolist()]
        commands = self.command.tolist()
        if self.command.size and int(self.command.min()) < 0:
            commands = [None if c < 0 else c for c in commands]
        commands2 = [None if c < 0 else c for c in self.command2.tolist()]
        status = _rows(self.status, self.n_status)
        gaps = _rows(self.gaps_ns, self.n_status)
        times = self.time.tolist() if self.time is not None else [""] * n
        epochs = self.epoch_ns.tolist() if self.epoch_ns is not None else [NO_EPOCH] * n
        word_errors = self.word_errors.tolist() if self.word_errors is not None else [()] * n
        new = object.__new__
        cls = MonitorRecord
        (set_t, set_bus, set_format, set_command, set_data, set_status, set_gaps, set_errors,
         set_command2, set_word_errors, set_end, set_extra) = SLOT_SETTERS
        out: list[MonitorRecord] = []
        append = out.append
        for (t, end, bus, fmt, command, command2, block, channel, d, state, gap, mask,
             text, epoch, named) in zip(
                self.t_ns.tolist(), self.end_ns.tolist(), buses, formats, commands, commands2,
                self.block_status.tolist(), self.channel.tolist(), data, status, gaps, masks,
                times, epochs, word_errors, strict=True):
            if block >= 0 and channel >= 0:
                extra: dict[str, object] = {"block_status": block, "channel": channel}
            else:
                extra = {}
                if block >= 0:
                    extra["block_status"] = block
                if channel >= 0:
                    extra["channel"] = channel
            if text:
                extra["time"] = text
            if epoch != NO_EPOCH:
                extra["epoch_ns"] = epoch
            record = new(cls)
            set_t(record, t)
            set_bus(record, bus)
            set_format(record, fmt)
            set_command(record, command)
            set_data(record, d)
            set_status(record, state)
            set_gaps(record, gap)
            set_errors(record, names[mask])
            set_command2(record, command2)
            set_word_errors(record, named)
            set_end(record, end)
            set_extra(record, extra)
            append(record)
        return out

    def take(self, keep: npt.NDArray[np.bool_] | npt.NDArray[np.intp] | slice) -> Ms1553Batch:
        """The messages ``keep`` selects: a mask, indexes or a slice (``words`` shared)."""
        return Ms1553Batch(
            self.t_ns[keep], self.end_ns[keep], self.bus[keep], self.format[keep],
            self.command[keep], self.command2[keep], self.block_status[keep],
            self.channel[keep], self.offset[keep], self.data_start[keep], self.data_count[keep],
            self.status[keep], self.n_status[keep], self.gaps_ns[keep], self.errors[keep],
            self.words, None if self._time is None else self._time.take(keep)
            if isinstance(self._time, TimeText) else self._time[keep],
            None if self.epoch_ns is None else self.epoch_ns[keep],
            None if self.word_errors is None else self.word_errors[keep])

    @classmethod
    def from_records(cls, records: Sequence[MonitorRecord]) -> Ms1553Batch:
        """Records packed into the columns (what a monitor whose backend makes records hands
        out as batches): ``command``/``command2`` -1 where there is none (stray words),
        ``block_status``, ``channel``, ``time`` and ``epoch_ns`` from each record's ``extra``
        (-1, "" or :data:`NO_EPOCH` where it has none), ``offset`` -1, and ``word_errors``
        kept. ``from_records(r).records() == r``, message for message, when each record has
        at most two status words and one response gap per status word (as every 1553
        message has)."""
        n = len(records)
        words: list[int] = []
        starts, counts = [], []
        width = max((len(r.status) for r in records), default=0)
        width = max(width, 2)
        status = np.zeros((n, width), np.int64)
        gaps = np.zeros((n, width), np.int64)
        for i, r in enumerate(records):
            starts.append(len(words))
            counts.append(len(r.data))
            words += r.data
            if r.status:
                status[i, :len(r.status)] = r.status
            if r.gaps_ns:
                gaps[i, :min(len(r.gaps_ns), width)] = r.gaps_ns[:width]
        masks = [_error_mask(r.errors) for r in records]
        times = [str(r.extra.get("time", "")) for r in records]
        epochs = [int(r.extra.get("epoch_ns", NO_EPOCH)) for r in records]
        named = np.empty(n, object)
        named[:] = [r.word_errors for r in records]

        def col(values: Sequence[int]) -> I64:
            return np.asarray(values, np.int64).reshape(-1)

        return cls(
            t_ns=col([r.t_ns for r in records]), end_ns=col([r.end_ns for r in records]),
            bus=np.asarray([r.bus == "B" for r in records], np.uint8).reshape(-1),
            format=np.asarray([_FORMAT_CODE[r.format] for r in records], np.uint8
                              ).reshape(-1),
            command=col([-1 if r.command is None else r.command for r in records]),
            command2=col([-1 if r.command2 is None else r.command2 for r in records]),
            block_status=col([int(r.extra.get("block_status", -1)) for r in records]),
            channel=col([int(r.extra.get("channel", -1)) for r in records]),
            offset=np.full(n, -1, np.int64), data_start=col(starts), data_count=col(counts),
            status=status, n_status=col([len(r.status) for r in records]), gaps_ns=gaps,
            errors=col(masks), words=np.asarray(words, np.uint16),
            _time=np.asarray(times, "<U32") if any(times) else None,
            epoch_ns=col(epochs) if any(e != NO_EPOCH for e in epochs) else None,
            word_errors=named if any(r.word_errors for r in records) else None)


_BUS_NAMES = ("A", "B")


def _rows(values: I64, kept: I64) -> list[tuple[int, ...]]:
    """Row i of ``values`` up to column ``kept[i]``, each a tuple."""
    if values.ndim != 2 or values.shape[1] == 0:
        return [()] * len(kept)
    return [tuple(row[:k]) for row, k in zip(values.tolist(), kept.tolist(), strict=True)]


def _error_mask(names: tuple[str, ...]) -> int:
    mask = 0
    for name in names:
        mask |= ERROR_BIT[name]
    return mask


@lru_cache(maxsize=4096)
def error_names(mask: int) -> tuple[str, ...]:
    """The sorted error names of a bit set."""
    return tuple(sorted(name for name, bit in ERROR_BIT.items() if mask & bit))


@dataclass(frozen=True, slots=True)
class _Plan:
    format: int
    data_start: int
    data_count: int
    n_status: int
    positions: tuple[int, int]
    owners: tuple[int, int]
    expected: int
    errors: int


@lru_cache(maxsize=16384)
def _plan(key: int) -> _Plan:
    command, command2 = key & 0xFFFF, (key >> 16 & 0x1FFFF) - 1
    n, timed_out = key >> 33 & 0x1FFFF, bool(key >> 50 & 1)
    plan = split_plan(command, None if command2 < 0 else command2, n, timed_out)
    positions = [p for p, _ in plan.status_positions] + [0, 0]
    owners = [o for _, o in plan.status_positions] + [-1, -1]
    mask = 0
    for name in plan.errors:
        mask |= ERROR_BIT[name]
    return _Plan(_FORMAT_CODE[plan.format], plan.data_start, plan.data_count,
                 len(plan.status_positions), (positions[0], positions[1]),
                 (owners[0], owners[1]), plan.expected_words, mask)


def build_batch(parts: Parts, timebase: Timebase, timing: BusTiming | None = None
                ) -> Ms1553Batch | None:
    """The batch of the messages gathered in ``parts`` (None when there are none)."""
    if not parts.bodies:
        return None
    timing = timing or _TIMING
    walked = gather(parts)
    rtc, block, gap, first = walked.rtc, walked.block, walked.gap, walked.first
    n, stamp_bit, words = walked.n_words, walked.stamp_bit, walked.words
    w = words.astype(np.int64)
    command = w[first]
    has2 = ((block & RT_TO_RT) != 0) & (n > 1)
    command2 = np.where(has2, w[np.minimum(first + 1, w.size - 1)], -1)
    timed_out = (block & RESPONSE_TIMEOUT) != 0
    key = command | (command2 + 1) << 16 | n << 33 | timed_out.astype(np.int64) << 50
    shapes, inverse = np.unique(key, return_inverse=True)
    plans = [_plan(int(k)) for k in shapes.tolist()]

    def column(values: list[int]) -> I64:
        return np.asarray(values, np.int64)[inverse]

    fmt = column([p.format for p in plans])
    data_start = first + column([p.data_start for p in plans])
    data_count = column([p.data_count for p in plans])
    n_status = column([p.n_status for p in plans])
    expected = column([p.expected for p in plans])
    errors = column([p.errors for p in plans])
    gaps = np.stack([(gap & 0xFF) * 100, (gap >> 8) * 100], axis=1)
    status = np.zeros((rtc.size, 2), np.int64)
    for j in range(2):
        present = n_status > j
        pos = column([p.positions[j] for p in plans])
        owner = column([p.owners[j] for p in plans])
        word = np.where(present, w[np.minimum(first + pos, w.size - 1)], 0)
        status[:, j] = word
        errors |= np.where(present & (word >> 11 != owner), ERROR_BIT["wrong_rt_address"], 0)
        errors |= np.where(present & (word & _STATUS_RESERVED != 0),
                           ERROR_BIT["reserved_status_bits"], 0)
        g = gaps[:, j]
        measured = present & (g != 0)
        errors |= np.where(measured & (g < timing.response_min_ns),
                           ERROR_BIT["early_response"], 0)
        errors |= np.where(measured & (g >= timing.response_min_ns)
                           & (g > timing.response_max_ns), ERROR_BIT["late_response"], 0)
    for bit, name in ((RESPONSE_TIMEOUT, "no_response"), (FORMAT_ERROR, "illegal_format"),
                      (SYNC_TYPE_ERROR, "sync"), (INVALID_WORD_ERROR, "word_error")):
        errors |= np.where(block & bit != 0, ERROR_BIT[name], 0)
    count_error = block & WORD_COUNT_ERROR != 0
    errors |= np.where(count_error & (n > expected), ERROR_BIT["word_count_high"],
                       np.where(count_error, ERROR_BIT["word_count_low"], 0))
    kept_gaps = np.where(np.arange(2) < n_status[:, None], gaps, 0)
    span = n * WORD_TIME_NS + np.maximum(kept_gaps - CONTIGUOUS_GAP_NS, 0).sum(axis=1)
    origin = timebase.origin if timebase.origin is not None else int(rtc[0])
    timebase.start(origin)
    stamp = _signed_delta(rtc, origin) * RTC_NS
    start = np.where(stamp_bit == TIME_TAG_LAST_BIT, stamp - span,
                     np.where(stamp_bit == TIME_TAG_COMMAND_END, stamp - WORD_TIME_NS, stamp))
    time_text, epoch = _times(parts.refs, walked.ref_id, rtc, start - stamp)
    return Ms1553Batch(
        t_ns=start, end_ns=start + span, bus=((block & BUS_B) != 0).astype(np.uint8),
        format=fmt.astype(np.uint8), command=command, command2=command2, block_status=block,
        channel=walked.channel, offset=walked.offset,
        data_start=data_start, data_count=data_count, status=status, n_status=n_status,
        gaps_ns=gaps, errors=errors, words=words, _time=time_text, epoch_ns=epoch)


def _signed_delta(rtc: I64, reference: int) -> I64:
    delta = (rtc - (reference & _RTC_MASK)) % _RTC_MOD
    return np.where(delta >= _RTC_HALF, delta - _RTC_MOD, delta)


def _times(refs: list[TimeReference | None], ref_id: I64, rtc: I64, shift: I64
           ) -> tuple[TimeText | None, I64 | None]:
    """Absolute time text (to be worked out when first read) and epoch ns of every message,
    from the time reference in force when its packet was read (``refs[ref_id]``)."""
    if all(ref is None for ref in refs):
        return None, None
    epoch = None
    for number, ref in enumerate(refs):
        if ref is None or ref.date is None:
            continue
        rows = np.flatnonzero(ref_id == number)
        if epoch is None:
            epoch = np.full(rtc.size, NO_EPOCH, np.int64)
        epoch[rows] = _epoch(rtc[rows], shift[rows], ref, ref.date)
    if epoch is not None and bool((epoch == NO_EPOCH).all()):
        epoch = None
    return TimeText(refs, ref_id, rtc, shift), epoch


@dataclass(frozen=True, slots=True)
class TimeText:
    """What a batch's ``time`` column is made from, kept until it is first read (reading
    a recording's batches seldom needs the text, and making it is a good part of the cost
    of reading)."""

    refs: list[TimeReference | None]
    ref_id: I64
    rtc: I64
    shift: I64

    def take(self, keep: npt.NDArray[np.bool_] | npt.NDArray[np.intp] | slice) -> TimeText:
        return TimeText(self.refs, self.ref_id[keep], self.rtc[keep], self.shift[keep])

    def text(self) -> npt.NDArray[np.str_]:
        text = np.full(self.rtc.size, "", "<U32")
        for number, ref in enumerate(self.refs):
            if ref is None:
                continue
            rows = np.flatnonzero(self.ref_id == number)
            if rows.size:
                text[rows] = _text(self.rtc[rows], self.shift[rows], ref)
        return text


def _epoch(rtc: I64, shift: I64, ref: TimeReference, date: datetime) -> I64:
    """:meth:`Timebase.epoch_ns` (moved by ``shift``, from the stamp to the message's
    start) for every message."""
    delta = _signed_delta(rtc, ref.rtc)
    return (date - _EPOCH) // timedelta(microseconds=1) * 1000 + delta * RTC_NS + shift


def _text(rtc: I64, shift: I64, ref: TimeReference) -> npt.NDArray[np.str_]:
    """:meth:`Timebase.absolute` for every message."""
    delta = _signed_delta(rtc, ref.rtc)
    # timedelta(microseconds=delta / 10) rounds half to even
    whole, tenth = np.divmod(delta, 10)
    micros = whole + ((tenth > 5) | ((tenth == 5) & (whole % 2 == 1)))
    if ref.date is not None:
        base = np.datetime64(ref.date, "us")
    else:
        assert ref.day_of_year is not None
        base = np.datetime64(datetime(2000, 1, 1) + timedelta(days=ref.day_of_year - 1,
                                                              seconds=ref.seconds_of_day), "us")
    moment = base + micros.astype("timedelta64[us]")
    if ref.date is not None:
        text: npt.NDArray[np.str_] = np.datetime_as_string(moment, unit="us")
        return text
    day = moment.astype("datetime64[D]")
    yday = (day - day.astype("datetime64[Y]")).astype(np.int64) + 1
    clock = np.datetime_as_string(moment, unit="us")
    return np.char.add(np.char.add("day ", np.char.zfill(yday.astype(str), 3)),
                       np.char.add(" ", np.char.partition(clock, "T")[:, 2]))
