"""JSON lines of a whole :class:`~drivers.chapter10.ms1553_batch.Ms1553Batch` at once.

``mapr decode FILE.c10`` prints each 1553 message as ``json.dumps`` of
:meth:`MonitorRecord.to_json` plus ``channel``, ``time`` and ``values``. Building a dict and
dumping it per message cost more than reading the file, so here the text is assembled from
pieces, byte for byte what ``json.dumps`` gives:

* the part fixed by bus, format and command word(s) (``"bus"`` to ``"sa2"``) is formatted
  once per distinct combination (a flight has a few hundred) and broadcast;
* words are turned into text once per batch, and each line is one f-string over slices.

``values`` (engineering values from an ICD) come as text too, ready to put before the
closing brace (:mod:`mapr_daemon.cli.icdview.batch`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from drivers.chapter10.ms1553_batch import FORMATS, Ms1553Batch, error_names
from drivers.mil1553.words import MODE_SUBADDRESSES


def _prefix(bus: int, fmt: int, command: int, command2: int) -> str:
    """``"bus": ..., "format": ..., "rt": ... "sa2": ..., `` as json.dumps writes them."""
    out = f'"bus": "{"B" if bus else "A"}", "format": "{FORMATS[fmt]}", '
    sa = command >> 5 & 31
    out += f'"rt": {command >> 11 & 31}, "tr": "{"T" if command >> 10 & 1 else "R"}", ' \
           f'"sa": {sa}, '
    if sa in MODE_SUBADDRESSES:
        out += f'"mode_code": {command & 31}, '
    else:
        out += f'"wc": {(command & 31) or 32}, '
    if command2 >= 0:
        out += f'"rt2": {command2 >> 11 & 31}, "sa2": {command2 >> 5 & 31}, '
    return out


def _errors(mask: int) -> str:
    return "[" + ", ".join(f'"{name}"' for name in error_names(mask)) + "]"


def json_lines(batch: Ms1553Batch, tails: Sequence[str] | None = None) -> list[str]:
    """One JSON object per message, newline-terminated, as ``mapr decode`` prints them
    (``tails``: per message, text to put before its closing brace: the ICD's engineering
    values as ``, "values": {...}``, or nothing)."""
    n = len(batch)
    if n == 0:
        return []
    key = (batch.bus.astype(np.int64) | batch.format.astype(np.int64) << 1
           | batch.command << 5 | (batch.command2 + 1) << 21)
    kinds, inverse = np.unique(key, return_inverse=True)
    prefixes = [_prefix(int(k) & 1, int(k) >> 1 & 15, int(k) >> 5 & 0xFFFF,
                        (int(k) >> 21) - 1) for k in kinds.tolist()]
    masks, mask_index = np.unique(batch.errors, return_inverse=True)
    error_text = [_errors(m) for m in masks.tolist()]
    data = _data_text(batch)
    status = _pair_text(batch.status, batch.n_status)
    gaps = _pair_text(batch.gaps_ns, batch.n_status)
    times = [""] * n if batch.time is None else \
        [f', "time": "{t}"' if t else "" for t in batch.time.tolist()]
    extra = [""] * n if tails is None else tails
    prefix = [prefixes[k] for k in inverse.tolist()]
    errors = [error_text[k] for k in mask_index.tolist()]
    return [f'{{"t_ns": {t}, {p}"data": [{d}], "status": [{s}], "gaps_ns": [{g}], '
            f'"errors": {e}, "channel": {c}{tm}{x}}}\n'
            for t, p, d, s, g, e, c, tm, x in zip(
                batch.t_ns.tolist(), prefix, data, status, gaps, errors,
                batch.channel.tolist(), times, extra, strict=True)]


_WORD_TEXT = [str(i) for i in range(1 << 16)]
_WORD_CHARS = np.array([len(t) for t in _WORD_TEXT], np.int64)


def _data_text(batch: Ms1553Batch) -> list[str]:
    """Each message's data words as ``1, 2, 3``: every word of the batch is joined into
    one string once, and each message's text is a slice of it."""
    words = batch.words
    text = ", ".join(map(_WORD_TEXT.__getitem__, words.tolist())) + ", "
    ends = np.concatenate([[0], np.cumsum(_WORD_CHARS[words] + 2)])
    start = ends[batch.data_start]
    stop = ends[batch.data_start + batch.data_count] - 2
    stop = np.maximum(stop, start)
    return [text[a:b] for a, b in zip(start.tolist(), stop.tolist(), strict=True)]


def _pair_text(pairs: npt.NDArray[np.int64], kept: npt.NDArray[np.int64]) -> list[str]:
    """``a, b`` / ``a`` / empty per message (status words or gaps, ``kept`` of the two;
    values below 2**16), formatted once per distinct value."""
    key = pairs[:, 0] * (kept > 0) | (pairs[:, 1] * (kept > 1)) << 16 | kept << 32
    kinds, inverse = np.unique(key, return_inverse=True)
    text = [", ".join(map(str, (k & 0xFFFF, k >> 16 & 0xFFFF)[:k >> 32]))
            for k in kinds.tolist()]
    return [text[k] for k in inverse.tolist()]
