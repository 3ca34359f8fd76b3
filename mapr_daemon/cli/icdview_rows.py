"""The compiled writer of :mod:`mapr_daemon.cli.icdview_batch`: a whole batch's values text
in two kernel calls, numbers as ``json.dumps`` writes them.

The table is flattened once (:mod:`mapr_daemon.icd.flatdecode`) and its fixed texts (each
message's head, each field's key and brackets, labels, the flag lists of every flag byte)
put in a :class:`~drivers.jsontext.TextPool`. Per batch: one kernel decodes every cell of
every record the table describes (:func:`~mapr_daemon.icd.flatdecode.decode_cells`),
:func:`~drivers.jsontext.shortest_decimals` finds each number's text, ``repr`` writes the
few it cannot (NaN, infinities, -0.0, tiny or huge magnitudes), and one kernel writes every
record's text into one buffer (:func:`~drivers.jsontext.write_objects`), cut into one string
per record. No numpy pass runs per message or parameter.

Loading the kernels costs a process about 0.6 s of CPU once (numba and its code generator),
so this module is imported only when that pays (see
:class:`~mapr_daemon.cli.icdview_batch.BatchValues`).
"""

from __future__ import annotations

import json
import weakref

import numpy as np
import numpy.typing as npt

from drivers.chapter10.ms1553_batch import Ms1553Batch
from drivers.jsontext import NUMBER_BYTES, TextPool, shortest_decimals, write_objects
from mapr_daemon.icd import Icd
from mapr_daemon.icd.flags import FLAG_NAMES, flag_names
from mapr_daemon.icd.flatdecode import FlatTable, decode_cells, flatten
from mapr_daemon.icd.model import Message

I64 = npt.NDArray[np.int64]


class CompiledRows:
    """Values texts of the records of batches, for one table's messages; each text starts
    with ``lead`` (``{"message": ...}`` as ``json.dumps`` writes it follows)."""

    def __init__(self, messages: tuple[Message, ...], lead: str = "") -> None:
        self.table: FlatTable = flatten(messages)
        table = self.table
        pool = self._pool = TextPool()
        group = [{c.name for c in m.group.channels} if m.group else set() for m in messages]
        self.heads = pool.add_all([lead + '{"message": ' + json.dumps(m.name) for m in messages])
        opens, closes, keys = [], [], []
        for m in range(len(messages)):
            for f in range(table.field_start[m], table.field_start[m + 1]):
                key = json.dumps(table.fields[f].name)
                array = table.fields[f].name in group[m]
                opens.append(f", {key}: " + ("[" if array else ""))
                closes.append("]" if array else "")
                keys.append(f"{key}: ")
        self.field_open = pool.add_all(opens)
        self.field_close = pool.add_all(closes)
        self.field_key = pool.add_all(keys)
        labels = pool.add_all([json.dumps(label) for label in table.labels])
        self.label_entry = np.append(labels, -1)   # label index -> entry; -1 (none) -> -1
        every_flag = sum(bit for bit, _ in FLAG_NAMES)
        self.code_text = np.full(256, -1, np.int64)
        for bits in range(1, every_flag + 1):
            if bits & ~every_flag == 0:
                self.code_text[bits] = pool.add(json.dumps(sorted(flag_names(bits))))
        self.nan, self.inf, self.minus_inf = (pool.add(t) for t in
                                              ("NaN", "Infinity", "-Infinity"))
        self.marks_open, self.marks_close = pool.add(', "flags": {'), pool.add("}")
        self.tail = pool.add("}\n")   # a row per line: cut by one str.split
        self._static = pool.arrays()
        self._static_entries = self._static[1].size - 1
        self.fields_per_message = np.diff(table.field_start)
        longest = max(NUMBER_BYTES, pool.longest())
        fixed = np.array([len(o) + len(c) + len(k) + 2 + longest
                          for o, c, k in zip(opens, closes, keys, strict=True)], np.int64)
        field_fixed = np.concatenate([[0], np.cumsum(fixed)])
        self.bound = (np.array([pool.length(int(h)) for h in self.heads], np.int64)
                      + field_fixed[table.field_start[1:]] - field_fixed[table.field_start[:-1]]
                      + 16 + table.cells_per_message * (longest + 2))
        """Per message, the most bytes one record's text takes (from its head on)."""

    def texts(self, batch: Ms1553Batch, rows: I64, message: I64) -> list[str]:
        """The text of each record ``rows`` of ``batch`` (ascending), ``message[i]`` being
        the table's message number of ``rows[i]``."""
        if rows.size == 0:
            return []
        table = self.table
        count = batch.data_count[rows]
        empty = count <= 0
        cells = np.where(empty, 0, table.cells_per_message[message])
        row_cell = np.zeros(rows.size + 1, np.int64)
        np.cumsum(cells, out=row_cell[1:])
        value, _, flags, label = decode_cells(
            table, batch.words, batch.data_start[rows], count,
            (batch.errors[rows] != 0).astype(np.uint8), message, row_cell)
        text = self.label_entry[label]
        digits, mantissa = shortest_decimals(value)
        pool, starts = self._pool_arrays(value, digits, text)
        out = np.empty(int(self.bound[message].sum()), np.uint8)
        ends = np.empty(rows.size, np.int64)
        written = write_objects(
            pool, starts, self.heads[message], table.field_start[message],
            np.where(empty, 0, self.fields_per_message[message]), row_cell, self.field_open,
            self.field_close, self.field_key, np.diff(table.cell_start), text, digits,
            mantissa, flags, self.code_text, self.marks_open, self.marks_close, self.tail,
            out, ends)
        return str(out[:written].data, "ascii").split("\n")[:-1]

    def _pool_arrays(self, value: npt.NDArray[np.float64], digits: I64, text: I64
                     ) -> tuple[npt.NDArray[np.uint8], I64]:
        """The pool's bytes and starts for this batch: the fixed texts, then the ``repr``
        of each number :func:`shortest_decimals` leaves to it (``text`` set to them)."""
        data, starts = self._static
        slow = np.flatnonzero((digits < 0) & (text < 0))
        if slow.size == 0:
            return data, starts
        rest = value[slow]
        finite = np.isfinite(rest)
        text[slow[~finite]] = np.where(np.isnan(rest[~finite]), self.nan,
                                       np.where(rest[~finite] > 0, self.inf, self.minus_inf))
        numbers = list(map(repr, rest[finite].tolist()))
        text[slow[finite]] = self._static_entries + np.arange(len(numbers))
        added = "".join(numbers).encode("ascii")
        lengths = np.fromiter(map(len, numbers), np.int64, len(numbers))
        more = starts[-1] + np.cumsum(lengths)
        return (np.concatenate([data, np.frombuffer(added, np.uint8)]),
                np.concatenate([starts, more]))


_TABLES: weakref.WeakKeyDictionary[Icd, dict[str, CompiledRows]] = \
    weakref.WeakKeyDictionary()


def compiled_rows(icd: Icd, lead: str = "") -> CompiledRows:
    """The :class:`CompiledRows` of ``icd``'s messages, texts starting with ``lead`` (made
    once per table and lead)."""
    made = _TABLES.setdefault(icd, {})
    rows = made.get(lead)
    if rows is None:
        rows = made[lead] = CompiledRows(icd.messages, lead)
    return rows
