"""Message assembler: decoded words in, :class:`MonitorRecord` messages out.

Segmentation follows the bus as a monitor sees it. Each bus's word stream is split into
*transmissions* (runs of contiguous words, 2 µs apart mid-crossing to mid-crossing), every gap
is measured, and one pass applies the grammar of the ten transfer formats: a command (two for
RT-RT) with the BC's data, then, within the no-response time-out, each expected RT response
(status word, data). That pass is a compiled kernel (:mod:`drivers.mil1553.grammar`) that
returns message boundaries as numbers; Python only builds the records from them.
:mod:`tests.support.assembler_reference` keeps the same grammar in plain Python as its
specification. Everything found wrong is named in the record's
``errors``; nothing is dropped: words that fit no message become a record of their own
(``UNKNOWN``, ``orphan_words``).

Streaming: ``feed`` takes word batches in time order with a *horizon*, the time up to which the
word stream is known complete (a decoder's, or the last word's end when not given); a message
still waiting for a response or for more words at the horizon is kept for the next call.
"""

from __future__ import annotations

from collections.abc import Iterable
from itertools import chain
from operator import attrgetter

import numpy as np
import numpy.typing as npt

from drivers.mil1553.grammar import (
    CMD2,
    ERR,
    FMT,
    FORMATS,
    G0,
    G1,
    MESSAGE_COLUMNS,
    NEXT,
    NSTATUS,
    S0,
    S1,
    START,
    WBITS,
    parse_bus,
    timing_array,
)
from drivers.mil1553.record import (
    MESSAGE_ERROR_NAMES,
    MonitorRecord,
    TransferFormat,
    collector_paused,
    new_records,
)
from drivers.mil1553.timing import BusTiming
from drivers.mil1553.wordbatch import (
    BUS_NAMES,
    WORD_ERROR_NAMES,
    WordBatch,
    concat_words,
    empty_words,
    take_words,
)

_SPAN = attrgetter("t_ns", "end_ns")
_BY_TIME = attrgetter("t_ns")
_UNKNOWN = FORMATS.index(TransferFormat.UNKNOWN)
_WORD_ERROR = 1 << MESSAGE_ERROR_NAMES.index("word_error")


class MessageAssembler:
    """Turns a time-ordered word stream (both buses) into messages.

    >>> from drivers.mil1553.wordbatch import make_words
    >>> words = make_words([(0, 0, 1, 0x2822), (20_000, 0, 0, 1), (40_000, 0, 0, 2),
    ...                     (66_000, 0, 1, 0x2800)])
    >>> [str(r.format) for r in MessageAssembler().feed(words, horizon_ns=200_000)]
    ['BC_RT']
    """

    def __init__(self, timing: BusTiming | None = None, *, time_tags: bool = True) -> None:
        self.timing = timing or BusTiming()
        self.time_tags = time_tags
        """False for word cards without time tags: response times are then not judged, nor
        is a both-buses overlap (host arrival times say nothing about microseconds: under
        load a retry on bus B arrives in the host time of the message it retried)."""
        self._pending: dict[int, WordBatch] = {0: empty_words(), 1: empty_words()}
        self._previous_end: dict[int, int | None] = {0: None, 1: None}
        self._superseded = {0: False, 1: False}
        self._recent: dict[str, list[tuple[int, int]]] = {bus: [] for bus in BUS_NAMES}
        self._timing_array = timing_array(self.timing)

    def feed(self, words: WordBatch, horizon_ns: int | None = None) -> list[MonitorRecord]:
        """Add words (sorted by time); return the messages completed, sorted by time."""
        records: list[MonitorRecord] = []
        if horizon_ns is None and words.size:
            horizon_ns = int(words["end_ns"].max())
        first_b = 0
        with collector_paused():
            for bus in (0, 1):
                # Rows copied as bytes (take_words, concat_words): numpy copies structured
                # rows field by field, several times slower.
                mine = take_words(words, np.flatnonzero(words["bus"] == bus))
                batch = concat_words([self._pending[bus], mine])
                done, used = self._assemble(batch, bus, horizon_ns)
                self._pending[bus] = batch[used:]
                records += done
                first_b = len(records) if bus == 0 else first_b
            return self._mark_both_buses(records, first_b)

    def flush(self) -> list[MonitorRecord]:
        """End of stream: close every message still open."""
        records: list[MonitorRecord] = []
        first_b = 0
        with collector_paused():
            for bus in (0, 1):
                done, _ = self._assemble(self._pending[bus], bus, None, final=True)
                self._pending[bus] = empty_words()
                records += done
                first_b = len(records) if bus == 0 else first_b
            return self._mark_both_buses(records, first_b)

    def _mark_both_buses(self, records: list[MonitorRecord], first_b: int | None = None
                         ) -> list[MonitorRecord]:
        """Flag messages overlapping in time with one on the other bus, this call's or a
        recent one's (an earlier message already returned cannot be flagged afterwards).
        ``records`` come out sorted by time (stable); ``first_b``, when given, says they are
        bus A's then, from that index, bus B's.

        Each record is tested against the other bus's last 64 spans (the recent ones, then
        this call's), as one numpy comparison per bus; not at all without time tags."""
        span = np.fromiter(chain.from_iterable(map(_SPAN, records)), dtype=np.int64,
                           count=2 * len(records)).reshape(-1, 2)
        if first_b is None:
            on_a = np.array([r.bus == "A" for r in records], dtype=np.bool_)
        else:
            on_a = np.arange(len(records)) < first_b
        order = np.argsort(span[:, 0], kind="stable")
        if (order[1:] < order[:-1]).any():
            records.sort(key=_BY_TIME)  # the same stable order, merged in C
            span, on_a = span[order], on_a[order]
        if not self.time_tags:
            return records
        t, end = span[:, 0], span[:, 1]
        spans = {}
        for bus, mine in (("A", on_a), ("B", ~on_a)):
            recent = np.array(self._recent[bus], dtype=np.int64).reshape(-1, 2)
            spans[bus] = np.concatenate([recent, np.stack([t[mine], end[mine]], axis=1)])
        out = list(records)
        hit = np.zeros(len(records), dtype=np.bool_)
        for bus, mine in (("A", on_a), ("B", ~on_a)):
            window = spans["B" if bus == "A" else "A"][-64:]
            if window.size and mine.any():
                # Some span (start, stop) of the window has start < end and stop > t: with
                # the window sorted by start, the spans starting before ``end`` are a prefix,
                # and one of them stops after ``t`` when the prefix's latest stop does.
                window = window[np.argsort(window[:, 0], kind="stable")]
                latest = np.maximum.accumulate(window[:, 1])
                before = np.searchsorted(window[:, 0], end[mine], side="left")
                hit[mine] = (before > 0) & (latest[np.maximum(before - 1, 0)] > t[mine])
        for index in np.flatnonzero(hit).tolist():
            out[index] = _with_error(out[index], "both_buses_active")
        for bus in BUS_NAMES:
            self._recent[bus] = [(int(a), int(b)) for a, b in spans[bus][-8:].tolist()]
        return out

    def assemble(self, words: WordBatch) -> list[MonitorRecord]:
        """All messages of a complete word stream (``feed`` then ``flush``); here every
        message on either side of a both-buses overlap is flagged."""
        return self._mark_both_buses(self.feed(words) + self.flush())

    # --- one bus ---------------------------------------------------------------------------
    def _assemble(self, batch: WordBatch, bus: int, horizon_ns: int | None,
                  final: bool = False) -> tuple[list[MonitorRecord], int]:
        """The complete messages of one bus's words and how many words they used."""
        if batch.size == 0:
            return [], 0
        t = batch["t_ns"].astype(np.int64)
        end = batch["end_ns"].astype(np.int64)
        value = batch["value"].astype(np.int64)
        word_errors = batch["errors"].astype(np.int64)
        out = np.empty((batch.size, len(MESSAGE_COLUMNS)), dtype=np.int64)
        previous = self._previous_end[bus]
        count, used, last_end, has_last, superseded = parse_bus(
            t, end, batch["sync"].astype(np.int64), value, word_errors,
            0 if horizon_ns is None else horizon_ns, horizon_ns is not None, final,
            self._timing_array, self.time_tags, 0 if previous is None else previous,
            previous is not None, self._superseded[bus], out)
        self._previous_end[bus] = int(last_end) if has_last else None
        self._superseded[bus] = bool(superseded)
        if count == 0:
            return [], int(used)
        return _records(out[:count], t, end, value, word_errors, BUS_NAMES[bus]), int(used)


def _records(out: npt.NDArray[np.int64], t: npt.NDArray[np.int64],
             end: npt.NDArray[np.int64], value: npt.NDArray[np.int64],
             word_errors: npt.NDArray[np.int64], bus: str) -> list[MonitorRecord]:
    """MonitorRecords from :func:`parse_bus`'s rows, built column by column: numpy finds
    each message's data, status words and gaps as runs of three flat lists, so the only
    per-message Python is a slice per field and the record itself."""
    start, after, fmt, command2 = out[:, START], out[:, NEXT], out[:, FMT], out[:, CMD2]
    statuses, errors, bits = out[:, NSTATUS], out[:, ERR], out[:, WBITS]
    known = fmt != _UNKNOWN
    # Every word of a message is a command, a status word or a data word.
    is_data = np.ones(int(after[-1]), dtype=np.bool_)
    is_data[start[known]] = False
    is_data[start[command2 >= 0] + 1] = False
    has0, has1 = statuses > 0, statuses > 1
    is_data[out[has0, S0]] = False
    is_data[out[has1, S1]] = False
    data_values = value[:is_data.size][is_data].tolist()
    data_end = np.cumsum(after - start - known - (command2 >= 0) - statuses).tolist()
    data_start = [0, *data_end[:-1]]
    status_index = np.stack([out[:, S0], out[:, S1]], axis=1)[np.stack([has0, has1], axis=1)]
    status_values = value[status_index].tolist()
    gap_values = np.stack([out[:, G0], out[:, G1]], axis=1)[np.stack([has0, has1], axis=1)
                                                            ].tolist()
    status_end = np.cumsum(statuses).tolist()
    status_start = [0, *status_end[:-1]]
    commands = value[start].tolist()
    error_names = [_ERROR_NAMES[e] for e in errors.tolist()]
    named: list[tuple[tuple[int, tuple[str, ...]], ...]] = [()] * start.size
    for m in np.flatnonzero(bits).tolist():
        first, last = int(start[m]), int(after[m])
        named[m], with_words = _word_errors(word_errors[first:last].tolist(), int(errors[m]))
        error_names[m] = _ERROR_NAMES[with_words]
    return new_records(
        t[start].tolist(), bus, [FORMATS[f] for f in fmt.tolist()],
        [c if k else None for c, k in zip(commands, known.tolist(), strict=True)],
        [tuple(data_values[a:b]) for a, b in zip(data_start, data_end, strict=True)],
        [tuple(status_values[a:b]) for a, b in zip(status_start, status_end, strict=True)],
        [tuple(gap_values[a:b]) for a, b in zip(status_start, status_end, strict=True)],
        error_names, [None if c < 0 else c for c in command2.tolist()], named,
        end[after - 1].tolist())


def _word_errors(bits: list[int], errors: int
                 ) -> tuple[tuple[tuple[int, tuple[str, ...]], ...], int]:
    """Each erroneous word's position in the message and error names; the message's error
    bits with those names and ``word_error`` added."""
    named = []
    for position, word in enumerate(bits):
        if word:
            names = tuple(name for bit, name in WORD_ERROR_NAMES if word & bit)
            named.append((position, names))
            for name in names:
                errors |= 1 << MESSAGE_ERROR_NAMES.index(name)
    return tuple(named), errors | _WORD_ERROR


class _ErrorNames(dict[int, tuple[str, ...]]):
    """Message error bit set -> sorted names, each set worked out once."""

    def __missing__(self, errors: int) -> tuple[str, ...]:
        names = tuple(sorted(name for i, name in enumerate(MESSAGE_ERROR_NAMES)
                             if errors >> i & 1))
        self[errors] = names
        return names


_ERROR_NAMES = _ErrorNames()


def _with_error(rec: MonitorRecord, name: str) -> MonitorRecord:
    from dataclasses import replace
    return replace(rec, errors=tuple(sorted({*rec.errors, name})))


def assemble(words: WordBatch | Iterable[WordBatch], timing: BusTiming | None = None
             ) -> list[MonitorRecord]:
    """Messages of a complete word stream."""
    assembler = MessageAssembler(timing)
    if isinstance(words, np.ndarray):
        return assembler.assemble(words)
    records: list[MonitorRecord] = []
    for batch in words:
        records += assembler.feed(batch)
    return records + assembler.flush()
