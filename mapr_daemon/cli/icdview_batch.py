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
    before: list[str] = []   # the fixed text before each cell (after the one before it)
    after = head
    values: list[npt.NDArray[np.float64]] = []
    labels: list[npt.NDArray[np.int64]] = []
    unions: list[npt.NDArray[np.uint8]] = []   # per parameter, each message's flags
    keys: list[str] = []
    for name, s in series.items():
        key = json.dumps(name)
        width = len(s) // count
        if name in group:   # an array, of one cell of no text when empty
            before += [f"{after}, {key}: ["] + [", "] * (max(width, 1) - 1)
            after = "]"
        else:   # a scalar
            before.append(f"{after}, {key}: ")
            after = ""
        if width:
            values.append(s.value.reshape(count, width))
            labels.append(_label_cells(pool, s.parameter, s.raw.reshape(count, width)))
        else:
            values.append(np.zeros((count, 1)))
            labels.append(np.full((count, 1), pool.add(""), np.int64))
        unions.append(s.flags if width == 1 else
                      np.bitwise_or.reduce(s.flags.reshape(count, width), axis=1))
        keys.append(f"{key}: ")
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
    flags = np.stack(unions, axis=1)
    entries = np.full(256, -1, np.int64)   # per flag byte seen, its list's pool entry
    for code in np.flatnonzero(np.bincount(flags.ravel(), minlength=256)[1:]).tolist():
        entries[code + 1] = pool.add(_flag_list(code + 1))
    mark_table = entries[flags]
    mark_key = pool.add_all(keys)
    prefix = pool.add_all(before)
    suffix = np.full(prefix.size, -1, np.int64)
    suffix[-1] = pool.add(after)
    tail, marks_open, marks_close = pool.add("}"), pool.add(', "flags": {'), pool.add("}")
    fixed = sum(map(len, before)) + len(after) + 1 + 1 + len(', "flags": {') + 1 + \
        sum(map(len, keys)) + 2 * len(keys)
    per_cell = max(NUMBER_BYTES, pool.longest())
    size = count * (fixed + per_cell * (value.shape[1] + len(keys)))
    buffer = np.empty(size, np.uint8)
    data_bytes, starts = pool.arrays()
    written = write_rows(data_bytes, starts, -1, prefix, suffix,
                         digits.reshape(value.shape), mantissa.reshape(value.shape),
                         np.ascontiguousarray(text), np.ascontiguousarray(mark_table),
                         mark_key, marks_open, marks_close, tail, buffer)
    return str(buffer[:written].data, "ascii").split("\n")[:-1]


def _label_cells(pool: TextPool, parameter: Parameter,
                 raw: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Per cell, the pool entry of its code's label (as JSON), or -1 where it has none."""
    cells = np.full(raw.shape, -1, np.int64)
    named = {code: label for code, label in parameter.labels.items() if label}
    if not named:
        return cells
    low, high = min(named), max(named)
    table = np.full(high - low + 1, -1, np.int64)   # code - low -> the label's entry
    for code, label in named.items():
        table[code - low] = pool.add(json.dumps(label))
    inside = (raw >= low) & (raw <= high)
    cells[inside] = table[raw[inside] - low]
    return cells


@lru_cache(maxsize=256)
def _flag_list(bits: int) -> str:
    return json.dumps(sorted(flag_names(bits)))
