"""Engineering values for a whole :class:`~drivers.chapter10.ms1553_batch.Ms1553Batch`.

:meth:`IcdView.values <mapr_daemon.cli.icdview.IcdView.values>` decodes one record at a
time (one numpy pass per message: fine for a live monitor, several times the cost of reading
for a recording; docs/figures.md). Here the messages of a batch are grouped by ICD message,
their data words stacked straight from the batch's word array, each group decoded in one
call and its text written by one ``%`` per message of a format string made once per message
layout, each distinct number of a column written once, short ones from tables and the rest by
``repr`` (:mod:`mapr_daemon.cli.icdview.numbers`); the result per message is the same dict,
key for key.

Once a decode has written enough values for loading numba to pay (:class:`BatchValues`), a
compiled writer takes over (:mod:`mapr_daemon.cli.icdview.rows`: the whole batch decoded
and written in two kernel calls, cheaper per message than this writer, as
bench/chapter10_speed.py prints; docs/figures.md); both write the same bytes.
"""

from __future__ import annotations

import json
import sys
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from drivers.chapter10.ms1553_batch import Ms1553Batch
from mapr_daemon.cli.icdview.numbers import number_parts
from mapr_daemon.icd import Icd
from mapr_daemon.icd.columns import distinct, message_numbers, stacked_series
from mapr_daemon.icd.flags import flag_names
from mapr_daemon.icd.model import Message
from mapr_daemon.icd.values import Series

COMPILED_AFTER = 200_000
"""Messages with values a decode writes with ``repr`` before it turns to the compiled
writer, unless numba is already loaded: loading it and its kernels costs a fixed CPU time
once and the compiled writer saves a little per such message, so it pays from about this many
on, where a fresh ``mapr decode --icd`` takes the same CPU time with either writer (the
figures, from bench/chapter10_speed.py: docs/figures.md, "Costs behind the code"). Traffic
whose values repeat favours the ``repr`` writer more."""


class BatchValues:
    """The values of the batches of one decode, in order, as ``json_lines`` takes them
    (``, "values": {...}`` per message, or nothing), each batch written the cheaper way
    given what the decode has written so far (see :data:`COMPILED_AFTER`)."""

    LEAD = ', "values": '

    def __init__(self, icd: Icd) -> None:
        self.icd = icd
        self.described = 0
        """Messages given values so far."""

    def __call__(self, batch: Ms1553Batch) -> list[str]:
        compiled = self.described >= COMPILED_AFTER or _numba_loaded()
        texts, described = _batch_texts(self.icd, batch, compiled, self.LEAD)
        self.described += described
        return texts


def _batch_texts(icd: Icd, batch: Ms1553Batch, compiled: bool, lead: str
                 ) -> tuple[list[str], int]:
    """Per message of ``batch``, ``lead`` and its values' JSON object, or "" if the table
    does not describe it, written by the compiled writer if ``compiled``; and how many
    messages the table describes."""
    if compiled:
        from mapr_daemon.cli.icdview.rows import compiled_rows

        names = message_numbers(icd, batch)
        return (compiled_rows(icd, lead).texts(batch, names),
                int(np.count_nonzero(names >= 0)))
    rows, texts = _described(icd, batch, lead)
    out = np.full(len(batch), "", dtype=object)
    out[rows] = texts
    placed: list[str] = out.tolist()
    return placed, len(rows)


def _numba_loaded() -> bool:
    """Whether this process has loaded numba already (the compiled writer is then cheap)."""
    return "numba" in sys.modules


def batch_values_json(icd: Icd, batch: Ms1553Batch, compiled: bool = False
                      ) -> list[str | None]:
    """Per message: the JSON text of ``{"message": name, parameter: value..., "flags":
    {...}}`` (what ``json.dumps`` of :meth:`IcdView.values` gives), or None; written by
    the compiled writer (:mod:`mapr_daemon.cli.icdview.rows`) if ``compiled``."""
    texts, _ = _batch_texts(icd, batch, compiled, "")
    return [text or None for text in texts]   # a described message's text is never empty


def _described(icd: Icd, batch: Ms1553Batch, lead: str) -> tuple[list[int], list[str]]:
    """The messages of ``batch`` the table describes and the text of each (``lead``, then
    the values' JSON object), by the Python writer."""
    names = message_numbers(icd, batch)
    places: list[int] = []
    texts: list[str] = []
    for code in distinct(names[names >= 0]).tolist():
        message = icd.messages[code]
        members = np.flatnonzero(names == code)
        head = lead + "{" + f'"message": {json.dumps(message.name)}'
        empty = members[batch.data_count[members] == 0].tolist()
        places += empty
        texts += [head + "}"] * len(empty)
        members = members[batch.data_count[members] > 0]
        if members.size:
            series = stacked_series(icd, message, batch, members)
            places += members.tolist()
            texts += _python_rows(message, series, members.size, head)
    return places, texts


def _python_rows(message: Message, series: dict[str, Series], count: int,
                 head: str) -> list[str]:
    """The whole text of each of ``count`` messages of ``message`` from ``head`` on, given
    their decoded ``series`` (record-major): one ``%`` per message of a format string made
    once per message layout (``head``, the keys, a list's brackets for group channels, a
    ``%s`` per number, then the flags), rather than a string per cell and a join per
    message (which cost as much as the numbers' ``repr``).

    The flags (``, "flags": {parameter: names, ...}`` where any is set) are columns too
    (:func:`_flag_columns`)."""
    if not series:
        return [head + "}"] * count
    group = {c.name for c in message.group.channels} if message.group else set()
    layout: list[tuple[str, int]] = []
    columns: list[list[str]] = []
    flagged: list[tuple[str, npt.NDArray[np.uint8]]] = []
    for name, s in series.items():
        width = len(s) // count
        layout.append((name, width if name in group else 0))
        text = _numbers(s)
        columns += [text] if width == 1 else [text[i::width] for i in range(width)]
        union = np.bitwise_or.reduce(s.flags.reshape(count, width), axis=1)
        if union.any():
            flagged.append((name, union))
    if flagged:
        columns += _flag_columns(flagged, count)
    return list(map(_row_format(head, tuple(layout), len(flagged)).__mod__,
                    zip(*columns, strict=True)))


@lru_cache(maxsize=256)
def _row_format(head: str, layout: tuple[tuple[str, int], ...], flagged: int) -> str:
    """The ``%`` format of a message's text: ``head``, then per parameter (name, samples;
    0 for a scalar) its key and a ``%s`` per sample, bracketed for a group channel; then,
    if ``flagged`` parameters have flags, a ``%s`` for the flags' opening, one per such
    parameter and one for the closing."""
    parts = []
    for name, samples in layout:
        key = json.dumps(name).replace("%", "%%")
        parts.append(f"{key}: [{', '.join(['%s'] * samples)}]" if samples else f"{key}: %s")
    flags = "%s" * (flagged + 2) if flagged else ""
    return head.replace("%", "%%") + ", " + ", ".join(parts) + flags + "}"


def _flag_columns(flagged: list[tuple[str, npt.NDArray[np.uint8]]], count: int
                  ) -> list[list[str]]:
    """The flags' columns for :func:`_row_format`: per message, the opening
    ``, "flags": {`` and the closing ``}`` where any of ``flagged`` (parameter name, flag
    bits of each message) is set, and between them per parameter its entry (parameter:
    its sorted flag names; after a comma if an earlier parameter has one) where it has
    flags; nothing elsewhere. Each distinct entry is written once, then indexed."""
    seen = np.zeros(count, dtype=np.intp)
    columns = []
    for name, bits in flagged:
        codes, inverse = np.unique(bits, return_inverse=True)
        first = [_flag_entry(name, code) for code in codes.tolist()]
        texts = np.array(first + [", " + t if t else "" for t in first], dtype=object)
        columns.append(texts[inverse + codes.size * seen].tolist())
        seen |= bits != 0
    return [_OPENING[seen].tolist(), *columns, _CLOSING[seen].tolist()]


_OPENING = np.array(["", ', "flags": {'], dtype=object)
_CLOSING = np.array(["", "}"], dtype=object)


@lru_cache(maxsize=4096)
def _flag_entry(name: str, bits: int) -> str:
    """``"name": [flag names]``, or nothing for no flags."""
    return f"{json.dumps(name)}: {flag_list(bits)}" if bits else ""


def _numbers(series: Series) -> list[str]:
    """The values of ``series`` as ``json.dumps`` writes them (an enumeration's label,
    quoted, where it has one for the raw code). Bus data repeats (codes, settled or slow
    signals, the same raw word read again), so each distinct value is written once
    (:func:`~mapr_daemon.cli.icdview.numbers.number_parts`, its two parts joined):
    distinct by its bits (the same bits, the same text; 0.0 and -0.0 apart), its text
    then repeated by index."""
    bits, inverse = np.unique(series.value.view(np.int64), return_inverse=True)
    heads, tails = number_parts(bits.view(np.float64))
    text = (heads + tails)[inverse]
    p = series.parameter
    if p.labels:
        codes, labels = _label_table(tuple(sorted(p.labels.items())))
        if codes.size:
            place = np.minimum(np.searchsorted(codes, series.raw), codes.size - 1)
            hit = codes[place] == series.raw
            text[hit] = labels[place[hit]]
    numbers: list[str] = text.tolist()
    return numbers


@lru_cache(maxsize=256)
def _label_table(items: tuple[tuple[int, str], ...]
                 ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.object_]]:
    """The codes that have a (non-empty) label, sorted, and each label's JSON text."""
    kept = [(code, label) for code, label in items if label]
    return (np.array([code for code, _ in kept], dtype=np.int64),
            np.array([json.dumps(label) for _, label in kept], dtype=object))


@lru_cache(maxsize=256)
def flag_list(bits: int) -> str:
    return json.dumps(sorted(flag_names(bits)))
