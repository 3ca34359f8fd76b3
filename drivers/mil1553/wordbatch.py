"""Decoded words in batches: a numpy structured array, one row per word.

This is the seam between the bit level (codec, or a card that decodes in hardware) and the
message assembler. Rows are sorted by time within a batch.

Fields
    ``t_ns``    time of the sync's leading edge, ns from capture start (int64)
    ``bus``     0 = bus A, 1 = bus B
    ``sync``    1 = command/status sync, 0 = data sync
    ``value``   the 16 data bits, bit 15 first on the bus
    ``errors``  bit set of :data:`WORD_ERROR_NAMES` (0 = clean)
    ``end_ns``  time of the last mid-bit crossing the word showed (parity bit's for a whole word),
                so gaps can be measured mid-crossing to mid-crossing as the standard defines them
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

WORD_DTYPE = np.dtype([
    ("t_ns", np.int64),
    ("bus", np.uint8),
    ("sync", np.uint8),
    ("value", np.uint16),
    ("errors", np.uint16),
    ("end_ns", np.int64),
])

WordBatch = npt.NDArray[Any]
"""A 1-D array of :data:`WORD_DTYPE`."""

SYNC_DATA = 0
SYNC_CMD = 1
BUS_A = 0
BUS_B = 1
BUS_NAMES = ("A", "B")
SYNC_NAMES = ("data", "cmd")

ERR_MANCHESTER = 1 << 0
ERR_PARITY = 1 << 1
ERR_BIT_COUNT_LOW = 1 << 2
ERR_BIT_COUNT_HIGH = 1 << 3
ERR_SYNC = 1 << 4

WORD_ERROR_NAMES: tuple[tuple[int, str], ...] = (
    (ERR_MANCHESTER, "manchester"),
    (ERR_PARITY, "parity"),
    (ERR_BIT_COUNT_LOW, "bit_count_low"),
    (ERR_BIT_COUNT_HIGH, "bit_count_high"),
    (ERR_SYNC, "sync"),
)
"""Word error classes, named as bus analyzers name them."""

WORD_TIME_NS = 20_000
"""One word on the bus: 3 µs sync + 16 data bits + parity, at 1 Mb/s."""


def empty_words(n: int = 0) -> WordBatch:
    """A zeroed batch of ``n`` words."""
    return np.zeros(n, dtype=WORD_DTYPE)


def concat_words(batches: Sequence[WordBatch]) -> WordBatch:
    """The batches one after the other (the only one as it is, when the others are empty).

    The rows are copied as bytes: numpy copies structured rows field by field, about ten
    times slower, which showed in the decoder's profile.
    """
    parts = [batch for batch in batches if batch.size]
    if len(parts) < 2:
        return parts[0] if parts else empty_words()
    raw = np.concatenate([np.ascontiguousarray(batch).view(np.uint8) for batch in parts])
    joined: WordBatch = raw.view(WORD_DTYPE)
    return joined


def take_words(words: WordBatch, order: npt.NDArray[np.intp]) -> WordBatch:
    """The rows ``order`` of ``words``, copied as bytes (see :func:`concat_words`)."""
    rows = np.ascontiguousarray(words).view(np.uint8).reshape(-1, WORD_DTYPE.itemsize)
    taken: WordBatch = np.take(rows, order, axis=0).view(WORD_DTYPE).reshape(-1)
    return taken


def error_names(errors: int) -> list[str]:
    """The names of the error bits set in ``errors``."""
    return [name for bit, name in WORD_ERROR_NAMES if errors & bit]


def error_bits(names: Iterable[str]) -> int:
    """The inverse of :func:`error_names`; unknown names raise ``ValueError``."""
    table = {name: bit for bit, name in WORD_ERROR_NAMES}
    bits = 0
    for name in names:
        if name not in table:
            raise ValueError(f"unknown word error {name!r}")
        bits |= table[name]
    return bits


def make_words(rows: Sequence[tuple[int, int, int, int]], errors: Sequence[int] | None = None
               ) -> WordBatch:
    """Build a batch from ``(t_ns, bus, sync, value)`` tuples (tests, hardware word cards).

    ``end_ns`` is set to the nominal parity mid-crossing, ``t_ns + 19.5 µs``.
    """
    out = empty_words(len(rows))
    if rows:
        arr = np.asarray(rows, dtype=np.int64).reshape(-1, 4)
        out["t_ns"] = arr[:, 0]
        out["bus"] = arr[:, 1]
        out["sync"] = arr[:, 2]
        out["value"] = arr[:, 3]
        out["end_ns"] = arr[:, 0] + WORD_TIME_NS - 500
    if errors is not None:
        out["errors"] = np.asarray(errors, dtype=np.uint16)
    return out


def word_to_json(row: Any) -> dict[str, Any]:
    """One word as the CLI prints it: ``{"t_ns", "bus", "sync", "value", "errors"}``."""
    return {
        "t_ns": int(row["t_ns"]),
        "bus": BUS_NAMES[int(row["bus"])],
        "sync": SYNC_NAMES[int(row["sync"])],
        "value": int(row["value"]),
        "errors": error_names(int(row["errors"])),
    }
