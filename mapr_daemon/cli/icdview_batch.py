"""Engineering values for a whole :class:`~drivers.chapter10.ms1553_batch.Ms1553Batch`.

:meth:`IcdView.values <mapr_daemon.cli.icdview.IcdView.values>` decodes one record at a
time (one numpy pass per message: fine for a live monitor, 7x the cost of reading for a
recording). Here the messages of a batch are grouped by ICD message, their data words
stacked straight from the batch's word array, and each group decoded in one call; the result
per message is the same dict, key for key.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from drivers.chapter10.ms1553_batch import FORMATS, Ms1553Batch
from drivers.mil1553.record import TransferFormat
from mapr_daemon.icd import Icd
from mapr_daemon.icd.flags import flag_names
from mapr_daemon.icd.model import Message

_DECODABLE = np.zeros(len(FORMATS), np.bool_)
for _code, _fmt in enumerate(FORMATS):
    _DECODABLE[_code] = _fmt in (TransferFormat.BC_RT, TransferFormat.RT_BC,
                                 TransferFormat.RT_RT, TransferFormat.BCAST_BC_RT,
                                 TransferFormat.BCAST_RT_RT)


def batch_values(icd: Icd, batch: Ms1553Batch) -> list[dict[str, Any] | None]:
    """Per message: ``{"message": name, parameter: value..., "flags": {...}}`` or None."""
    n = len(batch)
    out: list[dict[str, Any] | None] = [None] * n
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
        empty = members[batch.data_count[members] == 0]
        for i in empty.tolist():
            out[i] = {"message": message.name}
        members = members[batch.data_count[members] > 0]
        if not members.size:
            continue
        wc = message.word_count
        length = np.minimum(batch.data_count[members], wc)
        columns = np.arange(wc)
        present = columns[None, :] < length[:, None]
        at = np.where(present, batch.data_start[members, None] + columns[None, :], 0)
        data = np.where(present, batch.words[at], 0).astype(np.uint16)
        series = icd.decode_block(message.name, data, length.astype(np.intp),
                                  batch.t_ns[members], batch.errors[members] != 0)
        group = {c.name for c in message.group.channels} if message.group else set()
        columns_out = []
        for name, s in series.items():
            width = len(s) // members.size
            if s.parameter.labels:
                items = [s.parameter.label(r) or v for v, r in
                         zip(s.value.tolist(), s.raw.tolist(), strict=True)]
            else:
                items = s.value.tolist()
            flags = s.flags.reshape(members.size, width)
            flagged = set(np.flatnonzero(flags.any(axis=1)).tolist())
            columns_out.append((name, name in group, width, items, flags, flagged))
        for j, i in enumerate(members.tolist()):
            values: dict[str, Any] = {"message": message.name}
            marks: dict[str, list[str]] = {}
            for name, is_group, width, items, flags, flagged in columns_out:
                values[name] = items[j * width:(j + 1) * width] if is_group else items[j * width]
                if j in flagged:
                    marks[name] = sorted({f for v in flags[j].tolist() for f in flag_names(v)})
            if marks:
                values["flags"] = marks
            out[i] = values
    return out
