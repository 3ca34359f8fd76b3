"""Reading anchored words: bits, length and error flags from the crossings on their grid.

Once a word's grid is fixed (its *anchor*, the sync's start, in samples), each crossing goes
to the nearest half-bit slot, and crossings are counted per slot and direction for every word
at once with one ``bincount``. A good bit has exactly one crossing at its middle slot (its
direction is the bit: positive-to-negative = 1) and at most one at its start slot; a missing
mid-bit transition leaves the middle empty, a glitch adds a pair. Either way the word is
flagged ``manchester``. Where activity stops (or the next sync starts) gives the number of
bits sent: fewer than 17 is ``bit_count_low``, more is ``bit_count_high``. Parity is odd over
17 bits.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from drivers.mil1553.edges import FloatArray, IntArray
from drivers.mil1553.wordbatch import (
    ERR_BIT_COUNT_HIGH,
    ERR_BIT_COUNT_LOW,
    ERR_MANCHESTER,
    ERR_PARITY,
    SYNC_CMD,
    SYNC_DATA,
    WordBatch,
    empty_words,
)

FIRST_SLOT = 6
"""Half-bit slot of bit 0's first half (slots 0-5 are the sync)."""
BIT_SLOTS = 34
"""Slots 6-39: the first and second half of bits 0-16."""
_COLUMNS = BIT_SLOTS + 2
"""Per word and direction, the tally's columns: one before the bit slots and one after, where
every crossing outside them is counted and then ignored."""
_BIT_WEIGHTS = (1 << np.arange(15, -1, -1)).astype(np.int64)


def read_words(crossings: FloatArray, crossing_level: npt.NDArray[np.int8], anchors: FloatArray,
               first_owned: IntArray, stop: FloatArray, first_level: npt.NDArray[np.int8],
               rows: IntArray, *, half: float, base: int, sample_rate: float) -> WordBatch:
    """Bits, length and errors of the anchored words ``rows`` (``bus`` left 0).

    Word ``i`` owns the crossings from ``first_owned[i]`` up to the next word's (the last
    one, to the end); ``stop[i]`` is where its activity ends (samples, like ``anchors``);
    ``base`` is the sample index of the buffer's start in the capture, for the times in ns.
    Every owned crossing is placed in one pass over the crossings, without gathering: those
    outside the bit slots land in a column that is then ignored.
    """
    count = anchors.size
    if count == 0 or rows.size == 0:
        return empty_words()
    owned = crossings[first_owned[0]:]
    per_word = np.empty_like(first_owned)
    per_word[:-1] = first_owned[1:] - first_owned[:-1]
    per_word[-1] = crossings.size - first_owned[-1]
    position = np.repeat(anchors, per_word)
    np.subtract(owned, position, out=position)
    position /= half
    slot = np.rint(position, out=position).astype(np.int32)
    np.clip(slot, FIRST_SLOT - 1, FIRST_SLOT + BIT_SLOTS, out=slot)
    key = np.repeat(np.arange(-FIRST_SLOT + 1, count * _COLUMNS - FIRST_SLOT + 1, _COLUMNS,
                              dtype=np.int32), per_word)
    key += slot
    np.add(key, np.int32(count * _COLUMNS), out=key, where=crossing_level[first_owned[0]:] > 0)
    tally = np.bincount(key, minlength=2 * count * _COLUMNS).reshape(2, count, _COLUMNS)
    falling, rising = tally[0, rows], tally[1, rows]
    anchors, stop, first_level = anchors[rows], stop[rows], first_level[rows]
    words = empty_words(rows.size)
    hits = falling + rising
    mid, start = slice(2, _COLUMNS - 1, 2), slice(1, _COLUMNS - 2, 2)
    spus = 2 * half
    bits_sent = np.floor((stop - anchors) / spus - 3 + 0.25).astype(np.int64)
    present = np.arange(17)[None, :] < np.minimum(bits_sent, 17)[:, None]
    bad = (hits[:, mid] != 1) | (hits[:, start] > 1)
    manchester = np.any(bad & present, axis=1)
    ones = (falling[:, mid] > rising[:, mid]).astype(np.int64)
    parity_ok = (ones.sum(axis=1) & 1) == 1
    errors = np.where(manchester, ERR_MANCHESTER, 0)
    errors |= np.where(bits_sent < 17, ERR_BIT_COUNT_LOW, 0)
    errors |= np.where(bits_sent > 17, ERR_BIT_COUNT_HIGH, 0)
    errors |= np.where((bits_sent >= 17) & ~manchester & ~parity_ok, ERR_PARITY, 0)
    words["t_ns"] = np.rint((anchors + base) * 1e9 / sample_rate).astype(np.int64)
    last_mid = anchors + (3.5 + np.maximum(bits_sent, 1) - 1) * spus
    words["end_ns"] = np.rint((last_mid + base) * 1e9 / sample_rate).astype(np.int64)
    words["sync"] = np.where(first_level > 0, SYNC_CMD, SYNC_DATA)
    words["value"] = (ones[:, :16] @ _BIT_WEIGHTS).astype(np.uint16)
    words["errors"] = errors.astype(np.uint16)
    return words
