"""Every message of a table decoded in one compiled pass over a batch of records.

:class:`~mapr_daemon.icd.decoder.MessageDecoder` decodes one message's records with a dozen
numpy passes per parameter: right for the reasoner's series, but for a recording's text
output (``mapr decode --icd``) those passes, over a few records of each of many messages per
batch, cost as much as writing the text. Here the table is flattened once into arrays:

* per message, its range of *fields* (parameters, then group channels: the order of
  :meth:`MessageDecoder.decode`'s dict);
* per field, how to turn bits into a value (kind, bit offset, width, sign, scale, offset,
  limits, its enumeration codes) and its range of *cells*;
* per cell (one per sample: one for a scalar, one per group sample for a channel), the
  message words it reads and how many words must have come for it to be present.

:func:`decode_cells` then decodes the cells of every record of a batch, whatever its
message, into flat value / raw / flag / label arrays, exactly as the per-message decoder
does (the same IEEE operations in the same order, so the same bits).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from drivers.jit import kernel
from mapr_daemon.icd.flags import (
    FLAG_ABOVE_MAX,
    FLAG_BELOW_MIN,
    FLAG_INVALID,
    FLAG_MISSING,
    FLAG_NAN,
    FLAG_RECORD_ERROR,
)
from mapr_daemon.icd.model import Message, Parameter, ParamType
from mapr_daemon.icd.values import F64, I64, U8

U16 = npt.NDArray[np.uint16]

KIND_INTEGER, KIND_FLOAT32, KIND_BCD = 0, 1, 2
"""How a field's bits become a value: binary (signed or not), IEEE single, packed BCD."""

NO_LABEL = -1
"""A cell's label: none (its value is written as a number)."""


@dataclass(frozen=True, slots=True)
class FlatTable:
    """A table's messages, fields and cells as arrays (see the module doc)."""

    messages: tuple[Message, ...]
    word_count: I64
    """Per message, its data words (a record's words past them are not read)."""
    fields: tuple[Parameter, ...]
    """Every field of every message, message by message."""
    field_start: I64
    """Per message (and one more), its first field."""
    cell_start: I64
    """Per field (and one more), its first cell."""
    kind: I64
    lsb: I64
    width: I64
    signed: I64
    scaled: I64
    """1 where the value is ``raw * scale + offset`` (scale not 1 or offset not 0)."""
    scale: F64
    offset: F64
    low: F64
    high: F64
    check_codes: I64
    """1 where a code the field's labels do not list is flagged ``invalid``."""
    code_start: I64
    """Per field (and one more), its range of :attr:`codes`."""
    codes: I64
    """Each field's listed codes, sorted."""
    code_label: I64
    """Per listed code, its entry in :attr:`labels`, or :data:`NO_LABEL` (an empty label)."""
    labels: tuple[str, ...]
    col: I64
    """Per cell, the message word holding its (most significant) bits."""
    col_lo: I64
    """Per cell, the least significant word of a two-word value, or -1."""
    needed: I64
    """Per cell, the words a record must hold for the cell to be present."""

    @property
    def cells_per_message(self) -> I64:
        """Cells of one record of each message."""
        cells: I64 = self.cell_start[self.field_start[1:]] - self.cell_start[self.field_start[:-1]]
        return cells


def flatten(messages: tuple[Message, ...]) -> FlatTable:
    """The :class:`FlatTable` of ``messages`` (built once per table)."""
    field_start, cell_start, code_start = [0], [0], [0]
    fields: list[Parameter] = []
    per_field: list[tuple[int, int, int, int, int, float, float, float, float, int]] = []
    cols: list[tuple[int, int, int]] = []
    codes: list[int] = []
    code_label: list[int] = []
    labels: list[str] = []
    for message in messages:
        placed = [(p, [0]) for p in message.parameters]
        group = message.group
        if group is not None:
            bases = [group.start + i * group.stride for i in range(group.samples)]
            placed += [(c, bases) for c in group.channels]
        for p, bases in placed:
            fields.append(p)
            per_field.append(_field_row(p))
            for base in bases:
                words = p.word_indices(base)
                cols.append((words[0], words[1] if p.words == 2 else -1, max(words) + 1))
            cell_start.append(len(cols))
            for code in sorted(p.labels):
                codes.append(code)
                label = p.labels[code]
                code_label.append(len(labels) if label else NO_LABEL)
                if label:
                    labels.append(label)
            code_start.append(len(codes))
        field_start.append(len(fields))
    columns = list(zip(*per_field, strict=True)) if per_field else [()] * 10
    places = np.array(cols, np.int64).reshape(-1, 3)

    def ints(values: tuple[int, ...] | list[int]) -> I64:
        return np.array(values, np.int64)

    def floats(values: tuple[float, ...]) -> F64:
        return np.array(values, np.float64)

    return FlatTable(
        messages, ints([m.word_count for m in messages]), tuple(fields), ints(field_start),
        ints(cell_start),
        ints(columns[0]), ints(columns[1]), ints(columns[2]), ints(columns[3]),
        ints(columns[4]), floats(columns[5]), floats(columns[6]), floats(columns[7]),
        floats(columns[8]), ints(columns[9]), ints(code_start), ints(codes),
        ints(code_label), tuple(labels), np.ascontiguousarray(places[:, 0]),
        np.ascontiguousarray(places[:, 1]), np.ascontiguousarray(places[:, 2]))


def _field_row(p: Parameter) -> tuple[int, int, int, int, int, float, float, float, float, int]:
    """kind, lsb, width, signed, scaled, scale, offset, low, high, check_codes of ``p``, as
    :class:`~mapr_daemon.icd.decoder.FieldDecoder` decodes it."""
    if p.type is ParamType.FLOAT32:
        kind = KIND_FLOAT32
    elif p.type is ParamType.BCD:
        kind = KIND_BCD
    else:
        kind = KIND_INTEGER
    low = -np.inf if p.minimum is None else p.minimum - p.tolerance
    high = np.inf if p.maximum is None else p.maximum + p.tolerance
    scaled = int(p.scale != 1.0 or p.offset != 0.0)
    check = int(kind == KIND_INTEGER and bool(p.labels))
    return (kind, p.lsb, p.width, int(p.signed and kind == KIND_INTEGER), scaled,
            float(p.scale), float(p.offset), float(low), float(high), check)


def decode_cells(table: FlatTable, words: U16, data_start: I64, data_count: I64,
                 record_error: U8, row_message: I64, row_cell: I64
                 ) -> tuple[F64, I64, U8, I64]:
    """Value, raw code, flags and label entry of every cell of the given records.

    Record ``r`` is the batch's words ``words[data_start[r]:][:data_count[r]]``, of message
    number ``row_message[r]`` (an index of ``table.messages``); its cells go to
    ``row_cell[r]:row_cell[r + 1]`` of the outputs (``row_cell`` ascending; a record given
    no cells, one with no data words, is skipped). ``record_error[r]`` is nonzero where
    the record had bus errors."""
    return _decode(words, data_start, data_count, record_error, row_message, row_cell,
                   table.field_start, table.cell_start, table.kind, table.lsb, table.width,
                   table.signed, table.scaled, table.scale, table.offset, table.low,
                   table.high, table.check_codes, table.code_start, table.codes,
                   table.code_label, table.col, table.col_lo, table.needed, table.word_count)


@kernel
def _decode(words: U16, data_start: I64, data_count: I64, record_error: U8, row_message: I64,
            row_cell: I64, field_start: I64, cell_start: I64, kind: I64, lsb: I64,
            width: I64, signed: I64, scaled: I64, scale: F64, offset: F64, low: F64,
            high: F64, check_codes: I64, code_start: I64, codes: I64, code_label: I64,
            col: I64, col_lo: I64, needed: I64, word_count: I64
            ) -> tuple[F64, I64, U8, I64]:
    """:func:`decode_cells` over the table's arrays (one loop: record, field, cell)."""
    cells = row_cell[-1]
    value = np.empty(cells, np.float64)
    raw = np.empty(cells, np.int64)
    flags = np.zeros(cells, np.uint8)
    label = np.full(cells, NO_LABEL, np.int64)
    single = np.zeros(1, np.uint32)
    as_float = single.view(np.float32)
    for r in range(row_message.size):
        out = row_cell[r]
        if row_cell[r + 1] == out:
            continue
        m = row_message[r]
        start = data_start[r]
        length = min(data_count[r], word_count[m])
        error = np.uint8(FLAG_RECORD_ERROR) if record_error[r] else np.uint8(0)
        for f in range(field_start[m], field_start[m + 1]):
            mask = np.uint32((1 << width[f]) - 1)
            for c in range(cell_start[f], cell_start[f + 1]):
                word = np.uint32(words[start + col[c]]) if col[c] < length else np.uint32(0)
                if col_lo[c] >= 0:
                    lo = np.uint32(words[start + col_lo[c]]) if col_lo[c] < length \
                        else np.uint32(0)
                    word = (word << np.uint32(16)) | lo
                bits = (word >> np.uint32(lsb[f])) & mask
                code = np.int64(bits)
                flag = error
                if kind[f] == KIND_FLOAT32:
                    single[0] = bits
                    x = float(as_float[0])
                    if np.isnan(x):
                        flag |= np.uint8(FLAG_NAN)
                elif kind[f] == KIND_BCD:
                    x = 0.0
                    bad = False
                    weight = 1.0   # 10**k, exact
                    for k in range(width[f] // 4):
                        nibble = (bits >> np.uint32(4 * k)) & np.uint32(0xF)
                        if nibble > 9:
                            bad = True
                        x += np.float64(nibble) * weight
                        weight *= 10.0
                    if bad:
                        x = np.nan
                        flag |= np.uint8(FLAG_INVALID)
                else:
                    if signed[f]:
                        code -= (code >> (width[f] - 1)) << width[f]
                    x = float(code)
                if code_start[f + 1] > code_start[f]:
                    listed = codes[code_start[f]:code_start[f + 1]]
                    at = np.searchsorted(listed, code)
                    if at < listed.size and listed[at] == code:
                        label[out] = code_label[code_start[f] + at]
                    elif check_codes[f]:
                        flag |= np.uint8(FLAG_INVALID)
                if scaled[f]:
                    x = x * scale[f] + offset[f]
                if x < low[f]:
                    flag |= np.uint8(FLAG_BELOW_MIN)
                if x > high[f]:
                    flag |= np.uint8(FLAG_ABOVE_MAX)
                if length < needed[c]:
                    flag |= np.uint8(FLAG_MISSING)
                    x = np.nan
                value[out] = x
                raw[out] = code
                flags[out] = flag
                out += 1
    return value, raw, flags, label
