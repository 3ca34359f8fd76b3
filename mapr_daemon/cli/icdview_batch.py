"""Engineering values for a whole :class:`~drivers.chapter10.ms1553_batch.Ms1553Batch`.

:meth:`IcdView.values <mapr_daemon.cli.icdview.IcdView.values>` decodes one record at a
time (one numpy pass per message: fine for a live monitor, 7x the cost of reading for a
recording). Here the messages of a batch are grouped by ICD message, their data words
stacked straight from the batch's word array, and each group decoded in one call; the result
per message is the same dict, key for key.
"""

from __future__ import annotations

import json
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from drivers.chapter10.ms1553_batch import FORMATS, Ms1553Batch
from drivers.jsontext import NUMBER_BYTES, TextPool, shortest_decimals, write_rows
from drivers.mil1553.record import TransferFormat
from mapr_daemon.icd import Icd
from mapr_daemon.icd.flags import flag_names
from mapr_daemon.icd.model import Message, Parameter

_DECODABLE = np.zeros(len(FORMATS), np.bool_)
for _code, _fmt in enumerate(FORMATS):
    _DECODABLE[_code] = _fmt in (TransferFormat.BC_RT, TransferFormat.RT_BC,
                                 TransferFormat.RT_RT, TransferFormat.BCAST_BC_RT,
                                 TransferFormat.BCAST_RT_RT)


def batch_values_json(icd: Icd, batch: Ms1553Batch) -> list[str | None]:
    """Per message: the JSON text of ``{"message": name, parameter: value..., "flags":
    {...}}`` (what ``json.dumps`` of :meth:`IcdView.values` gives), or None."""
    n = len(batch)
    out: list[str | None] = [None] * n
    decodable = _DECODABLE[batch.format]
    pairs = batch.command << 17 | (batch.command2 + 1)
    names = np.full(n, -1, np.int64)
    messages: list[Message] = []
    index: dict[str, int] = {}
    for pair in np.unique(pairs[decodable]).tolist():
        command2 = (pair & 0x1FFFF) - 1
        message = icd.match_key(pair >> 17, None if command2 < 0 else command2)
        if message is None:
            continue
        if message.name not in index:
            index[message.name] = len(messages)
            messages.append(message)
        names[decodable & (pairs == pair)] = index[message.name]
    for code, message in enumerate(messages):
        members = np.flatnonzero(names == code)
        head = "{" + f'"message": {json.dumps(message.name)}'
        for i in members[batch.data_count[members] == 0].tolist():
            out[i] = head + "}"
        members = members[batch.data_count[members] > 0]
        if members.size:
            for i, text in zip(members.tolist(), _message_json(icd, message, batch, members,
                                                               head), strict=True):
                out[i] = text
    return out


def _message_json(icd: Icd, message: Message, batch: Ms1553Batch,
                  members: npt.NDArray[np.intp], head: str) -> list[str]:
    """The whole text for each of ``members`` (all of ``message``), from ``head`` on: one
    column of cells per sample of each parameter, written by :func:`write_rows`."""
    wc = message.word_count
    length = np.minimum(batch.data_count[members], wc)
    columns = np.arange(wc)
    present = columns[None, :] < length[:, None]
    at = np.where(present, batch.data_start[members, None] + columns[None, :], 0)
    data = np.where(present, batch.words[at], 0).astype(np.uint16)
    series = icd.decode_block(message.name, data, length.astype(np.intp),
                              batch.t_ns[members], batch.errors[members] != 0)
    group = {c.name for c in message.group.channels} if message.group else set()
    count = members.size
    pool = TextPool()
    prefix: list[int] = []
    suffix: list[int] = []
    values: list[npt.NDArray[np.float64]] = []
    labels: list[npt.NDArray[np.int64]] = []
    marks: list[npt.NDArray[np.int64]] = []
    mark_key: list[int] = []
    for name, s in series.items():
        key = json.dumps(name)
        width = len(s) // count
        if name in group:   # an array, of one cell of no text when empty
            cells = max(width, 1)
            prefix += [pool.add(f", {key}: [")] + [pool.add(", ")] * (cells - 1)
            suffix += [-1] * (cells - 1) + [pool.add("]")]
        else:   # a scalar
            prefix.append(pool.add(f", {key}: "))
            suffix.append(-1)
        if width:
            values.append(s.value.reshape(count, width))
            labels.append(_label_cells(pool, s.parameter, s.raw.reshape(count, width)))
        else:
            values.append(np.zeros((count, 1)))
            labels.append(np.full((count, 1), pool.add(""), np.int64))
        union = np.bitwise_or.reduce(s.flags.reshape(count, width), axis=1)
        if union.any():
            codes, inverse = np.unique(union, return_inverse=True)
            entries = np.array([pool.add(_flag_list(int(c))) if c else -1
                                for c in codes.tolist()], np.int64)
            marks.append(entries[inverse])
            mark_key.append(pool.add(f"{key}: "))
    if not values:
        return [head + "}"] * count
    value = np.concatenate(values, axis=1) if len(values) > 1 else values[0]
    text = np.concatenate(labels, axis=1) if len(labels) > 1 else labels[0]
    digits, mantissa = shortest_decimals(np.ascontiguousarray(value).ravel())
    slow = np.flatnonzero((digits < 0) & (text.ravel() < 0))
    if slow.size:   # NaN, infinities and the numbers only repr writes
        flat = text.ravel().copy()
        rest = value.ravel()[slow]
        finite = np.isfinite(rest)
        flat[slow[finite]] = pool.extend(list(map(repr, rest[finite].tolist())))
        flat[slow[~finite]] = np.where(np.isnan(rest[~finite]), pool.add("NaN"),
                                       np.where(rest[~finite] > 0, pool.add("Infinity"),
                                                pool.add("-Infinity")))
        text = flat.reshape(text.shape)
    mark_table = np.stack(marks, axis=1) if marks else np.full((count, 0), -1, np.int64)
    head_entry, tail = pool.add(head), pool.add("}")
    marks_open, marks_close = pool.add(', "flags": {'), pool.add("}")
    prefix_a, suffix_a = np.array(prefix, np.int64), np.array(suffix, np.int64)
    fixed = pool.length(head_entry) + pool.length(tail) + 1 + \
        sum(map(pool.length, prefix)) + sum(map(pool.length, suffix)) + \
        pool.length(marks_open) + pool.length(marks_close) + \
        sum(pool.length(k) + 2 for k in mark_key)
    per_cell = max(NUMBER_BYTES, pool.longest())
    size = count * (fixed + per_cell * (value.shape[1] + len(mark_key)))
    buffer = np.empty(size, np.uint8)
    data_bytes, starts = pool.arrays()
    written = write_rows(data_bytes, starts, head_entry, prefix_a, suffix_a,
                         digits.reshape(value.shape), mantissa.reshape(value.shape),
                         np.ascontiguousarray(text), np.ascontiguousarray(mark_table),
                         np.array(mark_key, np.int64), marks_open, marks_close, tail, buffer)
    return buffer[:written].tobytes().decode("ascii").split("\n")[:-1]


def _label_cells(pool: TextPool, parameter: Parameter,
                 raw: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Per cell, the pool entry of its code's label (as JSON), or -1 where it has none."""
    if not parameter.labels:
        return np.full(raw.shape, -1, np.int64)
    codes, inverse = np.unique(raw, return_inverse=True)
    entries = []
    for code in codes.tolist():
        label = parameter.label(code)
        entries.append(pool.add(json.dumps(label)) if label else -1)
    return np.array(entries, np.int64)[inverse].reshape(raw.shape)


@lru_cache(maxsize=256)
def _flag_list(bits: int) -> str:
    return json.dumps(sorted(flag_names(bits)))
