"""The compiled writer of :mod:`mapr_daemon.cli.icdview.batch`: a whole batch's values text
in two kernel calls, numbers as ``json.dumps`` writes them.

The table is flattened once (:mod:`mapr_daemon.icd.flatdecode`) and its fixed texts put in
a :class:`~mapr_daemon.cli.icdview.jsontext.TextPool`: per cell of each message, the text before it
(the
message's head, the field's key and bracket, the separator), per message the text after
its last cell, per field its key in the flags, labels, the flag lists of every flag byte.
Per batch: one kernel decodes every cell of every record the table describes
(:func:`~mapr_daemon.icd.flatdecode.decode_cells`),
:func:`~mapr_daemon.cli.icdview.jsontext.shortest_decimals` finds each number's text, ``repr``
writes the
few it cannot (NaN, infinities, -0.0, tiny or huge magnitudes), and one kernel writes every
record's text into one buffer (:func:`~mapr_daemon.cli.icdview.jsontext.write_rows`; a record the
table
does not describe, an empty line), cut into one string per record of the batch. No numpy
pass runs per message or parameter.

Loading the kernels costs a process a fixed CPU time once (numba and its code generator;
docs/figures.md), so this module is imported only when that pays (see
:class:`~mapr_daemon.cli.icdview.batch.BatchValues`).
"""

from __future__ import annotations

import json
import weakref

import numpy as np
import numpy.typing as npt

from drivers.chapter10.ms1553_batch import Ms1553Batch
from drivers.jit import COPY_BLOCK
from mapr_daemon.cli.icdview.jsontext import NUMBER_BYTES, TextPool, shortest_decimals, write_rows
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
        heads = [lead + '{"message": ' + json.dumps(m.name) for m in messages]
        self.heads = pool.add_all(heads)
        leads: list[str] = []
        """Per cell of the table, the text before it in a record's text (see
        :func:`~mapr_daemon.cli.icdview.jsontext.write_rows`)."""
        cell_key: list[int] = []
        closes: list[str] = []
        fixed: list[int] = []
        for m in range(len(messages)):
            pending = heads[m]
            for f in range(table.field_start[m], table.field_start[m + 1]):
                key = json.dumps(table.fields[f].name)
                array = table.fields[f].name in group[m]
                pending += f", {key}: " + ("[" if array else "")
                cells = int(table.cell_start[f + 1] - table.cell_start[f])
                for j in range(cells):
                    leads.append(pending + (", " if j else ""))
                    pending = ""
                    cell_key.append(pool.add(f"{key}: ") if j == cells - 1 else -1)
                pending += "]" if array else ""
                fixed.append(2 * len(key) + 10)   # its key, brackets and flags' key
            closes.append(pending)
        self.cell_lead = pool.add_all(leads)
        self.cell_key = np.array(cell_key, np.int64)
        self.closes = pool.add_all(closes)
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
        self.newline = pool.add("\n")  # a message the table does not describe
        self._static = pool.arrays()
        self._static_entries = self._static[1].size - 1
        self._static_text = self._static[0][:-COPY_BLOCK]
        longest = max(NUMBER_BYTES, pool.longest())
        field_fixed = np.concatenate([[0], np.cumsum(np.array(fixed, np.int64) + longest)])
        self.first_cell = table.cell_start[table.field_start[:-1]]
        self.bound = (np.array([len(h) for h in heads], np.int64)
                      + field_fixed[table.field_start[1:]] - field_fixed[table.field_start[:-1]]
                      + 16 + table.cells_per_message * (longest + 2))
        """Per message, the most bytes one record's text takes (from its head on)."""

    def texts(self, batch: Ms1553Batch, names: I64) -> list[str]:
        """The text of each record of ``batch``, ``names[i]`` being the table's message
        number of record ``i`` (-1: none, its text empty)."""
        if names.size == 0:
            return []
        table = self.table
        described = names >= 0
        message = np.where(described, names, 0)
        count = batch.data_count
        full = described & (count > 0)
        row_cells = np.where(full, table.cells_per_message[message], 0)
        row_cell = np.zeros(names.size + 1, np.int64)
        np.cumsum(row_cells, out=row_cell[1:])
        rows = np.flatnonzero(described)
        value, _, flags, label = decode_cells(
            table, batch.words, batch.data_start[rows], count[rows],
            (batch.errors[rows] != 0).astype(np.uint8), names[rows],
            np.append(row_cell[rows], row_cell[-1]))
        text = self.label_entry[label]
        digits, mantissa = shortest_decimals(value)
        pool, starts = self._pool_arrays(value, digits, text)
        out = np.empty(int(np.where(described, self.bound[message], 1).sum()) + COPY_BLOCK,
                       np.uint8)
        ends = np.empty(names.size, np.int64)
        head = np.where(described, self.heads[message], TextPool.EMPTY)
        written = write_rows(
            pool, starts, row_cells, row_cell, self.first_cell[message],
            np.where(full, self.closes[message], head),
            np.where(described, self.tail, self.newline), self.cell_lead, self.cell_key,
            text, digits, mantissa, flags, self.code_text, self.marks_open, self.marks_close,
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
        added = ("".join(numbers) + "\0" * COPY_BLOCK).encode("ascii")
        lengths = np.fromiter(map(len, numbers), np.int64, len(numbers))
        more = starts[-1] + np.cumsum(lengths)
        return (np.concatenate([self._static_text, np.frombuffer(added, np.uint8)]),
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
