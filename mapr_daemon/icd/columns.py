"""Decode a batch of 1553 messages held as columns (an :class:`Ms1553Batch`), no records built.

:meth:`Icd.decode_batch <mapr_daemon.icd.database.Icd.decode_batch>` takes
:class:`~drivers.mil1553.record.MonitorRecord` objects: right for a live monitor, whose
records come a few at a time. A Chapter 10 file is read as columns (one array per field, all
messages of many packets at once), and building a record per message only to stack their
words back into arrays costs more than decoding them (docs/figures.md). Here the
messages are matched to the table once per distinct pair of command words, each message's
data words gathered straight from the batch's word array, and each message decoded in one
call: :func:`decode_columns` returns what ``decode_batch`` returns for the batch's records
(series in the same order, the same counts; tests/chapter10/test_decode_columns.py checks
it).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from drivers.chapter10.ms1553_batch import FORMATS
from mapr_daemon.icd.database import DECODABLE_FORMATS, BatchResult
from mapr_daemon.icd.values import Series

if TYPE_CHECKING:
    from drivers.chapter10.ms1553_batch import Ms1553Batch
    from mapr_daemon.icd.database import Icd
    from mapr_daemon.icd.model import Message

DECODABLE = np.array([fmt in DECODABLE_FORMATS for fmt in FORMATS], np.bool_)
"""By format code of :data:`FORMATS`: whether the table can describe such a message
(:data:`~mapr_daemon.icd.database.DECODABLE_FORMATS`)."""


def message_numbers(icd: Icd, batch: Ms1553Batch) -> npt.NDArray[np.int64]:
    """Per message of ``batch``, the number (index in ``icd.messages``) of the table's
    message describing it, or -1; matched once per distinct pair of command words (and
    channel, when the table has terminals on channels)."""
    number = {message.name: k for k, message in enumerate(icd.messages)}
    decodable = DECODABLE[batch.format]
    pairs = batch.command << 17 | (batch.command2 + 1)
    names = np.full(len(batch), -1, np.int64)
    if icd.channels:   # terminals of one channel: a bus's command words are its own
        pairs = pairs | batch.channel.astype(np.int64) << 33
    for pair in distinct(pairs[decodable]).tolist():
        command2 = (pair & 0x1FFFF) - 1
        channel = pair >> 33 if icd.channels else None
        message = icd.match_key(pair >> 17 & 0xFFFF, None if command2 < 0 else command2,
                                channel)
        if message is not None:
            names[decodable & (pairs == pair)] = number[message.name]
    return names


def distinct(values: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """The distinct ``values``, sorted: ``np.unique`` without its indices, which imports
    ``numpy.ma`` on first use, a visible share of a short decode's CPU time (docs/figures.md)."""
    ordered = np.sort(values)
    keep = np.ones(ordered.size, dtype=np.bool_)
    keep[1:] = ordered[1:] != ordered[:-1]
    return ordered[keep]


def stacked_series(icd: Icd, message: Message, batch: Ms1553Batch,
                   members: npt.NDArray[np.intp]) -> dict[str, Series]:
    """The decoded parameters of ``members`` (all messages of ``message``, in batch order),
    their words stacked straight from the batch's word array as ``decode_batch`` stacks a
    record's: the first ``word_count`` words, zero-padded, with how many there were."""
    wc = message.word_count
    length = np.minimum(batch.data_count[members], wc)
    columns = np.arange(wc)
    present = columns[None, :] < length[:, None]
    at = np.where(present, batch.data_start[members, None] + columns[None, :], 0)
    data = np.where(present, batch.words[at], 0).astype(np.uint16)
    return icd.decode_block(message.name, data, length.astype(np.intp),
                            batch.t_ns[members], batch.errors[members] != 0)


def decode_columns(icd: Icd, batch: Ms1553Batch) -> BatchResult:
    """What ``icd.decode_batch(batch.records())`` returns, without building the records:
    the series of every message the table describes and carries data, grouped by message in
    the order each message first appears, and the counts."""
    result = BatchResult()
    names = message_numbers(icd, batch)
    known = names >= 0
    result.unmatched = int(np.count_nonzero(~known))
    carrying = known & (batch.data_count > 0)
    result.empty = int(np.count_nonzero(known)) - int(np.count_nonzero(carrying))
    if not carrying.any():
        return result
    rows = np.flatnonzero(carrying)
    codes = names[rows]
    order = np.argsort(codes, kind="stable")
    ordered = codes[order]
    starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])
    groups = np.split(rows[order], starts[1:])
    for members in sorted(groups, key=lambda m: int(m[0])):
        message = icd.messages[int(names[members[0]])]
        result.series.update(stacked_series(icd, message, batch, members))
        result.records[message.name] = int(members.size)
        result.data_words += int(np.minimum(batch.data_count[members],
                                            message.word_count).sum())
    return result
