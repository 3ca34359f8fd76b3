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
from drivers.mil1553.gridfit import range_indices
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
_BIT_WEIGHTS = (1 << np.arange(15, -1, -1)).astype(np.int64)


def bit_slots_end(crossings: FloatArray, anchors: FloatArray, half: float) -> IntArray:
    """Per anchor, the index of the first crossing past every crossing that can round to a
    bit slot (a bound: slots are checked exactly when the word is read)."""
    end: IntArray = np.searchsorted(crossings, anchors + (FIRST_SLOT + BIT_SLOTS) * half)
    return end


def read_words(crossings: FloatArray, crossing_level: npt.NDArray[np.int8], anchors: FloatArray,
               lo: IntArray, hi: IntArray, stop: FloatArray, first_level: npt.NDArray[np.int8],
               *, half: float, base: int, sample_rate: float) -> WordBatch:
    """Bits, length and errors of every anchored word (``bus`` left 0).

    ``crossings[lo[i]:hi[i]]`` are the crossings word ``i`` owns that may fall in its bit
    slots; ``stop[i]`` is where its activity ends (samples, like ``anchors``); ``base`` is the
    sample index of the buffer's start in the capture, for the times in ns.
    """
    count = anchors.size
    words = empty_words(count)
    if count == 0:
        return words
    index, per_word = range_indices(lo, hi)
    word = np.repeat(np.arange(count), per_word)
    slot = np.rint((crossings[index] - anchors[word]) / half).astype(np.int64)
    slot -= FIRST_SLOT
    inside = np.flatnonzero((slot >= 0) & (slot < BIT_SLOTS))
    key = (word[inside] * BIT_SLOTS + slot[inside]) * 2 + (crossing_level[index[inside]] > 0)
    tally = np.bincount(key, minlength=count * BIT_SLOTS * 2).reshape(count, BIT_SLOTS, 2)
    falling, rising = tally[:, :, 0], tally[:, :, 1]
    hits = falling + rising
    spus = 2 * half
    bits_sent = np.floor((stop - anchors) / spus - 3 + 0.25).astype(np.int64)
    present = np.arange(17)[None, :] < np.minimum(bits_sent, 17)[:, None]
    bad = (hits[:, 1::2] != 1) | (hits[:, 0::2] > 1)
    manchester = np.any(bad & present, axis=1)
    ones = (falling[:, 1::2] > rising[:, 1::2]).astype(np.int64)
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
