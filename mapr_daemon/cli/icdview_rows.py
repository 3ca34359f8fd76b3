"""The compiled writer of :mod:`mapr_daemon.cli.icdview_batch`: a group's values text in
one kernel call (:mod:`drivers.jsontext`), numbers as ``json.dumps`` writes them.

Per parameter sample a cell: its number, or a pool text (a label, NaN, or a number only
``repr`` writes); per parameter a flag-list cell where flags are set. Loading the kernels
costs a process about 0.6 s of CPU once (numba and its code generator), so this module is
imported only when that pays (see :class:`~mapr_daemon.cli.icdview_batch.BatchValues`).
"""

from __future__ import annotations

import json

import numpy as np
import numpy.typing as npt

from drivers.jsontext import NUMBER_BYTES, TextPool, shortest_decimals, write_rows
from mapr_daemon.cli.icdview_batch import flag_list
from mapr_daemon.icd.model import Message, Parameter
from mapr_daemon.icd.values import Series


def compiled_rows(message: Message, series: dict[str, Series], count: int,
                  head: str) -> list[str]:
    """The whole text of each of ``count`` messages of ``message`` from ``head`` on, given
    their decoded ``series`` (record-major): one column of cells per sample of each
    parameter, written by :func:`~drivers.jsontext.write_rows`."""
    group = {c.name for c in message.group.channels} if message.group else set()
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
        entries[code + 1] = pool.add(flag_list(code + 1))
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


